"""The thermal domain: one gear body, its facet groups and their thermal roles.

Roles of the exterior facets (every exterior facet must have exactly one):

* ``teeth`` — tips, flanks and roots: convection with h_t plus radiation;
* ``sides`` — the two side faces: convection with h_s plus radiation;
* ``bore`` — the inner surface: adiabatic (thesis) or a Robin heat path when the boundary model
  gives one;
* ``cuts`` — the cut faces (at mid-gap) of a fractional (sector) model: adiabatic, the thesis's
  choice, or tied periodically when the domain has a ``periodic`` rotation (the field is then
  the whole gear's for sources that are the same on every tooth; a one-tooth sector of a
  16-tooth gear with drive-flank heating is 0.17 K off the whole gear, adiabatic cuts 1.03 K).
  With rotation-averaged sources every tooth is heated alike, so adiabatic cut planes carry no
  net heat, and none at all when both flanks are heated alike (they are then symmetry planes;
  tested against a full gear). With drive-flank heating only, they carry a little heat: the
  teeth next to the cuts of the 8-tooth thesis gear are 2-4 K off the full gear at 40 W.

``monitors`` name the surface sets whose mean and maximum temperature are reported over time
(flank, coast flank, root, tip; interior teeth of a sector). ``model_fraction`` is the part of the
whole gear the mesh represents (8/30
for the thesis's fractional model) so that per-gear heat is scaled to the modelled sector.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_choice
from gearfem.core.rotation import RotationalPeriodicity

ROLES = ("teeth", "sides", "bore", "cuts")
TOOTH_SURFACES = ("drive_flank", "coast_flank", "tip", "root")


@dataclasses.dataclass(frozen=True, eq=False)
class ThermalDomain:
    """A mesh of one gear body with named facet groups.

    Args:
        mesh: DOLFINx mesh in metres.
        facet_tags: Facet MeshTags whose values identify the groups.
        groups: Group name -> facet tag values (e.g. ``"pinion_tooth3_drive_flank": (17,)``).
        teeth, sides, bore, cuts: Group names of each role (see the module docstring).
        monitors: Reported surface sets, name -> group names (e.g. ``"flank": (...)``).
        flux_surfaces: Default groups receiving the friction flux (drive flanks).
        model_fraction: Modelled fraction of the whole gear, in (0, 1].
        teeth_modelled: Number of teeth in the mesh (for per-tooth quantities), if a gear.
        parent_cells: When the mesh is a submesh (one body of a pair mesh): the parent-mesh cell of
            every local cell, for :meth:`cell_field_from_parent`.
        periodic: When given, the cut faces are not adiabatic but tied: the second group of
            ``cuts`` is the first turned by this rotation, and the temperature on it is the
            temperature at the corresponding point of the first (a rotationally periodic field,
            what rotation-averaged sources give; :mod:`gearfem.thermal.periodic`). The mesh's
            nodes on the two faces must correspond (``[thermal_mesh] periodic_cuts = true``).
    """

    mesh: object
    facet_tags: object
    groups: Mapping[str, tuple[int, ...]]
    teeth: tuple[str, ...]
    sides: tuple[str, ...]
    bore: tuple[str, ...] = ()
    cuts: tuple[str, ...] = ()
    monitors: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    flux_surfaces: tuple[str, ...] = ()
    model_fraction: float = 1.0
    teeth_modelled: int | None = None
    parent_cells: np.ndarray | None = None
    periodic: RotationalPeriodicity | None = None

    def __post_init__(self) -> None:
        if not (0.0 < self.model_fraction <= 1.0):
            raise ParameterError("domain.model_fraction", self.model_fraction, "(0, 1]")
        if self.periodic is not None and len(self.cuts) != 2:
            raise ParameterError(
                "domain.cuts", self.cuts, "two cut face groups (start, end) for a periodic tie"
            )
        for role in ROLES:
            for name in getattr(self, role):
                self._check_name(f"domain.{role}", name)
        for mon, names in self.monitors.items():
            if not names:
                raise ParameterError(f"domain.monitors.{mon}", names, "at least one facet group")
            for name in names:
                self._check_name(f"domain.monitors.{mon}", name)
        for name in self.flux_surfaces:
            self._check_name("domain.flux_surfaces", name)
        if not self.teeth and not self.sides:
            raise ParameterError(
                "domain.teeth", self.teeth, "at least one cooled surface group (teeth or sides)"
            )
        self._check_roles_cover_boundary()

    def _check_name(self, where: str, name: str) -> None:
        if name not in self.groups:
            raise ParameterError(
                where,
                name,
                "a facet group of the mesh: "
                + ", ".join(sorted(self.groups)[:12])
                + (" ..." if len(self.groups) > 12 else ""),
            )

    def tags(self, names: tuple[str, ...] | list[str]) -> tuple[int, ...]:
        """Facet tag values of the named groups (sorted, unique)."""
        out: set[int] = set()
        for n in names:
            self._check_name("facet group", n)
            out.update(int(v) for v in self.groups[n])
        return tuple(sorted(out))

    def role_tags(self, role: str) -> tuple[int, ...]:
        return self.tags(getattr(self, role))

    def facets(self, names: tuple[str, ...] | list[str]) -> np.ndarray:
        """Local facet indices of the named groups."""
        tags = np.asarray(self.tags(names), dtype=np.int32)
        ft = self.facet_tags
        return np.sort(ft.indices[np.isin(ft.values, tags)]).astype(np.int32)

    @property
    def comm(self):
        return self.mesh.comm

    def integration_entities(self, names: tuple[str, ...] | list[str]) -> np.ndarray:
        """The exterior facets of the named groups as integration entities (cell, local facet),
        as :func:`dolfinx.fem.get_integration_domains` gives them for their tags."""
        import dolfinx

        topology = self.mesh.topology
        tdim = topology.dim
        topology.create_connectivity(tdim - 1, tdim)
        topology.create_connectivity(tdim, tdim - 1)
        facets = np.intersect1d(self.facets(names), dolfinx.mesh.exterior_facet_indices(topology))
        return np.asarray(
            dolfinx.fem.compute_integration_domains(
                dolfinx.fem.IntegralType.exterior_facet, topology, facets.astype(np.int32)
            )
        )

    def surface_measure(self, surfaces: Mapping[int, tuple[str, ...]], metadata: dict):
        """The exterior facet measure whose subdomain ``i`` is the facets of the groups
        ``surfaces[i]``: forms over it carry the ids chosen by their caller, not the mesh's tag
        numbers, so the same form on another mesh (more teeth, other groups' tags) is the same
        compiled code (FFCx keys its cache by the form's subdomain ids)."""
        import ufl

        data = [(int(i), self.integration_entities(names)) for i, names in sorted(surfaces.items())]
        return ufl.Measure("ds", domain=self.mesh, subdomain_data=data, metadata=metadata)

    def _check_roles_cover_boundary(self) -> None:
        """Every exterior facet in exactly one role; no role overlaps (collective)."""
        import dolfinx

        mesh = self.mesh
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
        counts = np.zeros(
            mesh.topology.index_map(tdim - 1).size_local
            + mesh.topology.index_map(tdim - 1).num_ghosts,
            dtype=np.int32,
        )
        for role in ROLES:
            f = self.facets(getattr(self, role))
            counts[f] += 1
        n_local = mesh.topology.index_map(tdim - 1).size_local
        ext_owned = exterior[exterior < n_local]
        missing = int(np.count_nonzero(counts[ext_owned] == 0))
        overlap = int(np.count_nonzero(counts[:n_local] > 1))
        from mpi4py import MPI

        missing = mesh.comm.allreduce(missing, op=MPI.SUM)
        overlap = mesh.comm.allreduce(overlap, op=MPI.SUM)
        if missing:
            raise ParameterError(
                "domain roles",
                f"{missing} exterior facets without a role",
                "every exterior facet in teeth, sides, bore or cuts",
                "an untagged facet would silently be adiabatic",
            )
        if overlap:
            raise ParameterError(
                "domain roles",
                f"{overlap} facets in more than one role",
                "disjoint roles teeth, sides, bore, cuts",
            )

    # ------------------------------------------------------------------------------------------
    @classmethod
    def from_gear_mesh(
        cls, gear_mesh, body: str = "pinion", flux_flanks: str = "drive"
    ) -> ThermalDomain:
        """The domain of one body of a :class:`gearfem.geometry.mesh.GearMesh`.

        Uses ``gear_mesh.mesh``, ``facet_tags``, ``cell_tags``, ``physical_groups`` (name ->
        (dim, tag)), ``geometry.teeth_<body>``, and with ``options.periodic_cuts`` the body's
        axis ``center(body)`` for the periodic tie of the cut faces. When the mesh holds both
        bodies, the body's cells are extracted as a submesh (its facet tags transferred); a
        single-body mesh
        (``build_gear_mesh(..., bodies=("pinion",))``) is used as it is and is better balanced in
        parallel.
        """
        import dolfinx

        msh = gear_mesh.mesh
        tdim = msh.topology.dim
        groups = {
            name: (int(pg.tag),)
            for name, pg in gear_mesh.physical_groups.items()
            if int(pg.dim) == tdim - 1 and name.startswith(f"{body}_")
        }
        if body not in gear_mesh.physical_groups:
            raise ParameterError(
                "bodies", tuple(gear_mesh.physical_groups)[:4], f"a mesh containing {body!r}"
            )
        body_tag = int(gear_mesh.physical_groups[body].tag)
        ct = gear_mesh.cell_tags
        other = np.count_nonzero(ct.values != body_tag)
        from mpi4py import MPI

        ft = gear_mesh.facet_tags
        parent = None
        if msh.comm.allreduce(int(other), op=MPI.SUM) > 0:
            cells = np.sort(ct.find(body_tag)).astype(np.int32)
            sub, cell_map, vertex_map, _ = dolfinx.mesh.create_submesh(msh, tdim, cells)
            msh.topology.create_connectivity(tdim - 1, tdim)
            ft = dolfinx.mesh.transfer_meshtags_to_submesh(ft, sub, vertex_map, cell_map)
            im = sub.topology.index_map(tdim)
            parent = np.asarray(
                cell_map.sub_topology_to_topology(
                    np.arange(im.size_local + im.num_ghosts, dtype=np.int32), False
                ),
                dtype=np.int32,
            )
            msh = sub
        total = getattr(gear_mesh.geometry, f"teeth_{body}", None)
        dom = cls.from_gear_groups(
            msh, ft, groups, body=body, total_teeth=total, flux_flanks=flux_flanks
        )
        # a mesh built with periodic cut faces ties them: the end face is the start face turned
        # about the body's axis by the sector's angle
        periodic = None
        if getattr(gear_mesh.options, "periodic_cuts", None) and total is not None:
            periodic = RotationalPeriodicity(
                tuple(float(c) for c in gear_mesh.center(body)),
                2.0 * math.pi * dom.teeth_modelled / total,
            )
        return dataclasses.replace(dom, parent_cells=parent, periodic=periodic)

    def cell_field_from_parent(self, field):
        """A DG0 Function on this mesh from a DG0 Function on the parent (pair) mesh, cell by cell
        (e.g. U_max of the contact cycle); on a mesh that is not a submesh ``field`` must live on
        it."""
        from dolfinx import fem

        V = field.function_space
        if V.mesh is self.mesh:
            return field
        if self.parent_cells is None:
            raise ParameterError(
                "cell field", V.mesh, "a Function on the thermal mesh or on its parent mesh"
            )
        Q = fem.functionspace(self.mesh, ("DG", 0))
        out = fem.Function(Q, name=field.name)
        n = len(self.parent_cells)
        out.x.array[Q.dofmap.list[:n, 0]] = field.x.array[V.dofmap.list[self.parent_cells, 0]]
        return out

    @classmethod
    def from_gear_groups(
        cls,
        mesh,
        facet_tags,
        groups: Mapping[str, int | tuple[int, ...]],
        body: str = "pinion",
        total_teeth: int | None = None,
        flux_flanks: str = "drive",
    ) -> ThermalDomain:
        """Build the roles from the gearfem geometry naming convention.

        Groups named ``{body}_tooth{k}_{drive_flank|coast_flank|tip|root}`` are teeth,
        ``{body}_side_front``/``{body}_side_back`` sides, ``{body}_bore`` the bore and
        ``{body}_cut_start``/``{body}_cut_end`` (absent for a full gear) the cuts. Groups of other
        bodies are ignored (they must not carry facets of this mesh). Monitors: ``flank`` (the
        drive flanks), ``coast_flank``, ``tip``, ``root`` of the interior teeth of a sector (all
        teeth for a full gear or a sector of fewer than three teeth).

        Args:
            total_teeth: Teeth of the whole gear; with the teeth found in the mesh it gives
                ``model_fraction`` (None: the mesh is the whole gear).
            flux_flanks: ``"drive"``, ``"coast"`` or ``"both"``: default friction-flux surfaces.
        """

        require_choice("sources.flanks", flux_flanks, ("drive", "coast", "both"))
        grp = {
            k: ((int(v),) if np.isscalar(v) else tuple(int(x) for x in v))
            for k, v in groups.items()
        }
        pat = re.compile(rf"^{re.escape(body)}_tooth(\d+)_({'|'.join(TOOTH_SURFACES)})$")
        by_kind: dict[str, list[str]] = {k: [] for k in TOOTH_SURFACES}
        tooth_of: dict[str, int] = {}
        for name in sorted(
            grp, key=lambda n: (int(pat.match(n).group(1)) if pat.match(n) else -1, n)
        ):
            m = pat.match(name)
            if m:
                tooth_of[name] = int(m.group(1))
                by_kind[m.group(2)].append(name)
        tooth_ids = set(tooth_of.values())
        if not tooth_ids:
            raise ParameterError(
                "geometry facet groups",
                sorted(grp)[:6],
                f"groups named {body}_tooth<k>_<drive_flank|coast_flank|tip|root>",
            )
        teeth = tuple(n for k in TOOTH_SURFACES for n in by_kind[k])
        sides = tuple(n for n in (f"{body}_side_front", f"{body}_side_back") if n in grp)
        bore = tuple(n for n in (f"{body}_bore",) if n in grp)
        cuts = tuple(n for n in (f"{body}_cut_start", f"{body}_cut_end") if n in grp)
        n_teeth = len(tooth_ids)
        if total_teeth is None:
            fraction = 1.0
        else:
            if total_teeth < n_teeth:
                raise ParameterError(
                    "geometry.teeth", total_teeth, f">= {n_teeth} teeth found in the mesh"
                )
            if total_teeth > n_teeth and not cuts:
                raise ParameterError(
                    "geometry facet groups",
                    "no cut faces",
                    f"{body}_cut_start/_cut_end for a sector of {n_teeth} of {total_teeth} teeth",
                )
            fraction = n_teeth / total_teeth
        flux = {
            "drive": tuple(by_kind["drive_flank"]),
            "coast": tuple(by_kind["coast_flank"]),
            "both": tuple(by_kind["drive_flank"] + by_kind["coast_flank"]),
        }[flux_flanks]
        # Monitors over the interior teeth of a sector: next to an adiabatic cut the temperature
        # differs from the periodic (full-gear) solution when drive and coast flanks are heated
        # differently (8-tooth thesis gear, 40 W on the drive flanks: flank mean of the edge teeth
        # -2.4 / +3.6 K, interior teeth within 0.6 K of the full 30-tooth gear).
        ids = sorted(tooth_ids)
        interior = set(ids[1:-1]) if cuts and len(ids) >= 3 else set(ids)
        monitors = {
            k if k != "drive_flank" else "flank": tuple(n for n in v if tooth_of[n] in interior)
            for k, v in by_kind.items()
            if v
        }
        return cls(
            mesh=mesh,
            facet_tags=facet_tags,
            groups=grp,
            teeth=teeth,
            sides=sides,
            bore=bore,
            cuts=cuts,
            monitors=monitors,
            flux_surfaces=flux,
            model_fraction=fraction,
            teeth_modelled=n_teeth,
        )
