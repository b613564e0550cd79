"""The HWVEM figures read the right numbers from stored results."""

import numpy as np

import swarmnav
from swarmnav.methods.vicsek import VicsekFamily
from swarmnav.sim import RunResult
from swarmnav.viz import vicsek as V


def test_deg_con_from_stored_velocities_equals_the_methods_own(tmp_path):
    for model in ("hwvem", "vem"):
        m = VicsekFamily(model, v0=0.03, eta=0.0, c_rep=0.0, c_att=0.0)
        res = swarmnav.run(m, "periodic_box:n=60,rho=4.102", seed=1, steps=30)
        stored = RunResult.load(res.save(tmp_path / model))
        np.testing.assert_allclose(V.deg_con_series(stored), m.deg_series[1:], atol=1e-12)


def test_figures_are_written(tmp_path):
    m = VicsekFamily("hwvem", v0=0.03, eta=0.0, c_rep=0.0, c_att=0.0, stop_at_convergence=True)
    res = swarmnav.run(m, "periodic_box:n=60,rho=4.102", seed=1, steps=200)
    for path in (V.plot_snapshots(res, tmp_path / "f4.png"), V.plot_convergence({"hwvem": [res]}, tmp_path / "c.png")):
        assert path.stat().st_size > 10_000


def test_variant_names_of_swept_experiments():
    assert V._split_variant("p1=0.1[n=200]") == ("p1=0.1", 200)
    assert V._split_variant("with[eta=0,n=500]") == ("with", 500)
    assert V._split_variant("HWVEM") == ("HWVEM", None)
