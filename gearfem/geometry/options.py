"""The ``[mesh]`` options and the naming facts of the gear-pair mesh (DOLFINx- and gmsh-free)."""

from __future__ import annotations

from dataclasses import dataclass

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_choice, require_int, require_positive, require_range
from gearfem.geometry.involute import GearPairGeometry

#: Bump when a code change alters the generated meshes (part of the cache key). 2: tip rounds.
GEOMETRY_CODE_VERSION = "2"

#: How far the entry refinement (``size_entry_mm``) reaches above the start of active profile,
#: in modules (0.3 mm at m = 2): the loaded mate's tip round bears below and a little above it.
ENTRY_MARGIN_MODULES = 0.15

BODIES = ("pinion", "wheel")
TOOTH_KINDS = ("drive_flank", "coast_flank", "tip", "root")
BODY_KINDS = ("side_front", "side_back", "bore", "cut_start", "cut_end")


@dataclass(frozen=True)
class MeshOptions:
    """The ``[mesh]`` table: how the pair is meshed (sizes in mm).

    Attributes:
        teeth_in_model: N consecutive teeth of each gear (fractional model, thesis: 8);
            equal to the number of teeth for a full 360-degree gear. Checked against the gear's
            teeth when the model is built.
        element: ``"tet"`` (swept prisms split into tetrahedra) or ``"hex"`` (sweep of an
            all-quadrilateral section, every triangle split into three quadrilaterals: hexahedra
            only, because DOLFINx 0.11 cannot tag facets of mixed hex/prism meshes).
        order: Geometry/element order (2: 10-node tets or 27-node hexes, curved on the boundary).
        layers: Element layers across the face width (thesis: 3).
        layer_grading: How the layers are spaced across the face width: None (or 1) for equal
            layers; a ratio G > 1 grades them towards both side faces, where the free edges
            relieve the contact within a few tenths of a millimetre. The layer planes are
            ``z = b s(i / layers)`` with the size function ``s(xi) = (G^(2 xi) - 1) / (2 (G -
            1))`` on the front half (mirrored on the back half): the local layer thickness grows
            geometrically from the side faces to the middle by the factor G (the discrete
            thicknesses by G^(1 - 2 / layers) for an even count), and refining the layer count
            keeps the same size function (geometrically similar levels). 1 is stored as None,
            so that equal layers keep one cache key.
        size_flank_mm: Element size on the drive flanks of the refined teeth (profile direction;
            the Hertz half-width at 8 N m is about 0.3 mm).
        size_tip_mm: Size on the tips of the refined teeth.
        size_root_mm: Size on the root fillets and lands of the refined teeth.
        size_tooth_mm: Size on the coast flanks of the refined teeth and on all surfaces of the
            other teeth.
        size_entry_mm: Size at the entering and leaving pair's contacts of the refined teeth,
            or None (off, the default): on the drive-side tip round and on the drive flank from
            its foot up to ``ENTRY_MARGIN_MODULES`` modules above the start of active profile,
            where the mate's tip round bears (a contact about 80 um wide on the thesis gears at
            8 N m). Must not exceed ``size_flank_mm`` and ``size_tip_mm``.
        size_body_mm: Largest size (web, bore, cut faces).
        size_growth: Size gradient |grad h| of the grading away from the fine curves (the size
            grows linearly with the distance; 0.6 gives neighbour size ratios up to about 1.6 and
            2D angles >= 26 deg at the defaults).
        refined_teeth: Number of teeth in the middle of each sector meshed with the fine sizes
            (the loaded teeth; thesis: at most 4 loaded).
        pinion_angle_deg: Pinion rotation from the reference position (counter-clockwise); the
            wheel is placed at the rigid conjugate angle. Tooth numbering is unchanged.
        periodic_cuts: True meshes the two cut faces of a sector alike: the nodes of
            ``cut_end`` are those of ``cut_start`` turned by the sector's angle (gmsh's periodic
            meshes), so that a rotationally periodic condition can tie them (a sector standing
            for the whole gear). None (off; False is stored as None, so that other meshes keep
            their cache keys). Only for a sector (``teeth_in_model`` below the gear's teeth).
    """

    teeth_in_model: int = 8
    element: str = "tet"
    order: int = 2
    layers: int = 3
    layer_grading: float | None = None
    size_flank_mm: float = 0.12
    size_tip_mm: float = 0.15
    size_root_mm: float = 0.25
    size_tooth_mm: float = 0.8
    size_body_mm: float = 3.0
    size_growth: float = 0.6
    refined_teeth: int = 4
    size_entry_mm: float | None = None
    pinion_angle_deg: float = 0.0
    periodic_cuts: bool | None = None

    def __post_init__(self) -> None:
        p = "mesh."
        set_ = lambda k, v: object.__setattr__(self, k, v)
        if self.periodic_cuts not in (None, True, False):
            raise ParameterError(
                p + "periodic_cuts", self.periodic_cuts, "true or false (a TOML boolean)"
            )
        set_("periodic_cuts", True if self.periodic_cuts else None)
        set_("teeth_in_model", require_int(p + "teeth_in_model", self.teeth_in_model, lo=1))
        set_("element", require_choice(p + "element", self.element, ("tet", "hex")))
        set_("order", require_int(p + "order", self.order, lo=1, hi=2))
        set_("layers", require_int(p + "layers", self.layers, lo=1))
        if self.layer_grading is not None:
            g = require_range(
                p + "layer_grading",
                self.layer_grading,
                1.0,
                1000.0,
                reason="the middle layers' thickness over the side-face layers' (1: equal layers)",
            )
            set_("layer_grading", None if g == 1.0 else g)
        for key in (
            "size_flank_mm",
            "size_tip_mm",
            "size_root_mm",
            "size_tooth_mm",
            "size_body_mm",
        ):
            set_(key, require_positive(p + key, getattr(self, key)))
        set_("size_growth", require_range(p + "size_growth", self.size_growth, 0.05, 2.0))
        if self.size_entry_mm is not None:
            finest = min(self.size_flank_mm, self.size_tip_mm)
            set_(
                "size_entry_mm",
                require_range(
                    p + "size_entry_mm",
                    self.size_entry_mm,
                    0.0,
                    finest,
                    lo_open=True,
                    unit="mm",
                    reason="at most size_flank_mm and size_tip_mm (or absent: off)",
                ),
            )
        set_("refined_teeth", require_int(p + "refined_teeth", self.refined_teeth, lo=0))
        set_(
            "pinion_angle_deg",
            require_range(p + "pinion_angle_deg", self.pinion_angle_deg, -360.0, 360.0, unit="deg"),
        )


# ------------------------------------------------------------------------------------------------
# placement
# ------------------------------------------------------------------------------------------------


def reference_tooth(body: str, teeth_in_model: int) -> int:
    """Index of the tooth that touches at the pitch point in the reference position."""
    return teeth_in_model // 2 if body == "pinion" else (teeth_in_model - 1) // 2


def refined_tooth_indices(options: MeshOptions, teeth_in_model: int) -> list[int]:
    """The ``refined_teeth`` teeth in the middle of the sector."""
    n = min(options.refined_teeth, teeth_in_model)
    first = (teeth_in_model - n) // 2
    return list(range(first, first + n))


def check_bodies(bodies: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Which bodies to mesh, validated, in canonical order (``("pinion", "wheel")``, or one of
    them for a single gear). An argument of the mesh build, not a case-file key: the cycle needs
    both bodies, a thermal model one, whatever the case says."""
    given = tuple(bodies)
    if not given or len(set(given)) != len(given):
        raise ParameterError(
            "bodies", bodies, "a non-empty list of distinct names from 'pinion', 'wheel'"
        )
    for b in given:
        require_choice("bodies", b, BODIES)
    return tuple(b for b in BODIES if b in given)


def check_options(
    geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...] = BODIES
) -> None:
    """Checks that need both tables (N <= Z for each meshed body)."""
    for body in check_bodies(bodies):
        z = geometry.teeth(body)
        if options.teeth_in_model > z:
            raise ParameterError(
                "mesh.teeth_in_model",
                options.teeth_in_model,
                f"integer in [1, {z}]",
                f"the {body} has only {z} teeth",
            )
        if options.periodic_cuts and options.teeth_in_model == z:
            raise ParameterError(
                "mesh.periodic_cuts",
                True,
                f"only with teeth_in_model below the {body}'s {z} teeth",
                "a whole gear has no cut faces",
            )
