"""Diagnosis of friction laws (issue 15): a hidden friction law in synthetic data from the full
model must be found among its rivals.

As tests/test_diagnose.py (the coarse case, P1 thermal, the synthetic data from the full forward
model, the analysis on a surrogate cached under $GEARFEM_CACHE or ./cache), at two torques: the
pressure law is told from a friction scale only across loads. The data are end values only, as
the bench's are: each run is a steady solve (for a law whose heat may rise with temperature, the
lowest steady state, found by continuation), which made the surrogate's thermal runs take 60 s
instead of about 154 s with the transient to the 60 s samples (measured at 9058ce1, one core, the
cycles stored). A module of its own so that its
surrogate, the most expensive fixture of the suite, is built on another pytest-xdist worker than
the classic library's (dev.sh distributes the 1-rank tests by file).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import gearfem  # noqa: F401
from gearfem.diagnose.candidates import FRICTION_LAWS, by_name

sys.path.insert(0, str(Path(__file__).parent))
from test_diagnose import assert_hidden_effect_found, forward_models

#: Two torques (the pressure law is told from a friction scale only across loads) and two speeds
#: at the lower one (the sliding-speed law from convection), the bench points among them.
FRICTION_POINTS = ((600.0, 8.0), (1000.0, 8.0), (1000.0, 4.0), (2000.0, 4.0))
FRICTION_RIVALS = ("friction_scale", "friction_temperature", "convection_scale", "ambient_offset")
#: The candidates of the friction surrogate (timed by
#: benchmarks/performance/diagnose_surrogate_cost.py).
FRICTION_LIBRARY = FRICTION_LAWS + tuple(by_name(n) for n in FRICTION_RIVALS)


@pytest.fixture(scope="session")
def friction_models():
    return forward_models(FRICTION_LIBRARY, FRICTION_POINTS, times_s=())


@pytest.mark.slow
@pytest.mark.parametrize("name", [c.name for c in FRICTION_LAWS])
def test_friction_law_hidden_effect_found(friction_models, name):
    assert_hidden_effect_found(*friction_models, name, points=FRICTION_POINTS)


@pytest.mark.slow
def test_forward_state_returns_friction_heat_and_branch(friction_models):
    """The forward model returns the friction heat and, for a law whose heat may rise with T, the
    steady states and the branch the transient picked; the heat lies between the glassy and the
    rubbery plateaus' heats."""
    full, _ = friction_models
    base = full.evaluate_state(1000.0, 8.0, 23.0)
    assert base.steady_states is None and base.friction_per_gear_W > 0
    st = full.evaluate_state(1000.0, 8.0, 23.0, {"friction_glass_transition": 0.1})
    assert st.steady_states is not None and st.steady_states >= 1
    assert st.transient_branch is not None
    assert 0.2 * base.friction_per_gear_W - 1e-9 <= st.friction_per_gear_W
    assert st.friction_per_gear_W <= base.friction_per_gear_W * (1 + 1e-6)
    assert {b["start"] for b in st.branches} >= {"cold", "transient", "hot"}
    # evaluate skips the branch search, which runs after the temperatures are taken: the same
    # temperatures to round-off (two evaluations of one model differ by up to 2e-12 K run to run)
    again = full.evaluate(1000.0, 8.0, 23.0, {"friction_glass_transition": 0.1})
    assert again.keys() == st.temperatures_C.keys()
    for k, v in again.items():
        assert v == pytest.approx(st.temperatures_C[k], abs=1e-9), k


@pytest.mark.slow
def test_kept_thermal_parts_give_the_runs_built_anew(friction_models):
    """A diagnosis's runs keep the thermal mesh and domain, the U_max field, the flank transfer
    and the friction law's contact instances (gearfem.core.kept): each run on kept parts gives
    what the same run built anew gives, for the cycle's constant mu, a law recomputed once from
    the contact history and a law whose heat may rise with temperature (its instances kept under
    another law's flux)."""
    from gearfem import pipeline
    from gearfem.core.kept import forget_all
    from gearfem.coupling import friction_heat, heat_sources

    full, _ = friction_models
    models = (
        {},
        {"friction_pressure": -0.2},
        {"friction_glass_transition": 0.2},
        {"friction_glass_transition": 0.3},
    )
    stores = (
        pipeline.KEPT_DOMAINS,
        heat_sources.KEPT_U_MAX,
        heat_sources.KEPT_TRANSFERS,
        friction_heat.KEPT_INSTANCES,
    )
    forget_all()
    hits = [s.hits for s in stores]
    kept = [full.evaluate(1000.0, 8.0, 23.0, m) for m in models]
    assert all(s.hits > h for s, h in zip(stores, hits)), [s.hits for s in stores]
    for m, got in zip(models, kept):
        forget_all()
        anew = full.evaluate(1000.0, 8.0, 23.0, m)
        assert got.keys() == anew.keys()
        for k, v in anew.items():
            assert got[k] == pytest.approx(v, rel=1e-12, abs=1e-12), (m, k)
