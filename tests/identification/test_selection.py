"""The generic selection method (euc_sim.identification.selection) on synthetic regression problems.

The residual noise here is filtered (correlated) like the diagnosis' residual; every
draw is seeded.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from euc_sim.identification import regression as reg
from euc_sim.identification import selection as sel

N = 1200
T = np.linspace(0.0, 40.0, N)          # 30 Hz for 40 s


def _noise(seed: int, sd: float = 0.2, sigma: float = 6.0) -> np.ndarray:
    """Correlated noise: white noise through a Gaussian (σ = 6 samples), scaled to sd."""
    z = gaussian_filter1d(np.random.default_rng(seed).normal(size=N), sigma)
    return sd * z / z.std()


def _signals(seed: int = 0):
    rng = np.random.default_rng(seed)
    speed = 2.0 + np.sin(2 * np.pi * T / 13.0) + 0.3 * np.sin(2 * np.pi * T / 3.1 + rng.uniform(0, 6))
    lean = 0.1 * np.sin(2 * np.pi * T / 4.3) + 0.05 * np.sin(2 * np.pi * T / 1.7)
    return speed, lean


def _problem(true: dict, seed: int, h_true: float = 0.6, sd: float = 0.2, validity=None):
    """y(h) = (h − h_true)·lean·30 + Σ θ X + noise; candidates const, speed², lean rate, twin."""
    speed, lean = _signals(seed)
    cands = {"const": np.ones(N), "quad": speed * np.abs(speed), "rate": np.gradient(lean, T),
             "twin": np.ones(N) + 0.002 * np.sin(T)}          # near-collinear with const
    signal = sum(v * cands[k] for k, v in true.items())
    e = _noise(seed + 100, sd)
    hook = 30.0 * lean

    def target(h):
        return (h - h_true) * hook + signal + e

    return reg.Problem(target, cands, T, (0.2, 1.2), validity=validity or {})


def test_correlation_time_white_and_correlated():
    rng = np.random.default_rng(1)
    assert reg.correlation_time(rng.normal(size=20000)) == pytest.approx(1.0, abs=0.2)
    # AR(1) with ρ = 0.9: τ_int = (1 + ρ)/(1 − ρ) = 19
    x = np.zeros(20000)
    z = rng.normal(size=20000)
    for i in range(1, x.size):
        x[i] = 0.9 * x[i - 1] + z[i]
    assert reg.correlation_time(x) == pytest.approx(19.0, rel=0.15)


def test_fit_set_recovers_nuisance_and_coefficient():
    prob = _problem({"quad": 0.3}, seed=2)
    f = reg.fit_set(prob, ("quad",))
    assert f.h == pytest.approx(0.6, abs=0.01)
    assert f.theta["quad"][0] == pytest.approx(0.3, rel=0.05)
    f0 = reg.fit_set(prob, ())
    assert f0.rss > f.rss


def test_forward_select_finds_the_term_and_its_interval_covers_truth():
    prob = _problem({"quad": 0.3}, seed=3)
    s = sel.forward_select(prob, n_eff=N / reg.correlation_time(_noise(103)))
    assert s.selected == ("quad",)
    cov, dof = reg.covariance(prob, s.fit)
    se = np.sqrt(cov[0, 0])
    assert abs(s.fit.theta["quad"][0] - 0.3) < 3 * se
    assert s.cv_final < 0.5 * s.cv_nominal
    # the history keeps every trial of every step
    assert len(s.history) >= 2 and len(s.history[1].trials) == len(prob.candidates)
    assert s.history[-1].accepted is False


def test_interval_covers_when_the_residual_is_correlated_beyond_the_blocks():
    """Twin experiment: a residual correlated over ~1.5 s (a slow misfit), 2 s blocks.

    The cluster sandwich alone treats neighbouring blocks as independent and covered
    the truth in about 74 % of these draws; raised to the autocorrelation-scaled
    variance it covers about 92 %.
    """
    from scipy import stats

    speed, lean = _signals(0)
    X = speed * np.abs(speed)
    covered, n = 0, 100
    for s in range(n):
        e = _noise(500 + s, 0.2, sigma=45.0)

        def target(h, e=e):
            return (h - 0.6) * 30.0 * lean + 0.05 * X + e

        prob = reg.Problem(target, {"quad": X}, T, (0.2, 1.2))
        f = reg.fit_set(prob, ("quad",))
        cov, dof = reg.covariance(prob, f)
        covered += int(abs(f.theta["quad"][0] - 0.05) <= stats.t.ppf(0.975, dof) * np.sqrt(cov[0, 0]))
    assert covered / n >= 0.88


def test_forward_select_null_selects_nothing():
    prob = _problem({}, seed=4)
    s = sel.forward_select(prob, n_eff=N / reg.correlation_time(_noise(104)))
    assert s.selected == ()
    assert s.fit.h == pytest.approx(0.6, abs=0.02)


def test_validity_refusal_lets_the_next_candidate_in():
    # "const" fits best but is declared unphysical: "twin" (its near-copy) must not be
    # preferred blindly either; here it is refused too, and "rate" is the real term
    refuse = {"const": lambda th: "refused for the test", "twin": lambda th: "refused for the test"}
    prob = _problem({"const": 0.5, "rate": 2.0}, seed=5, validity=refuse)
    s = sel.forward_select(prob, n_eff=N / reg.correlation_time(_noise(105)))
    assert "rate" in s.selected
    assert "const" not in s.selected and "twin" not in s.selected
    assert "refused for the test" in s.history[1].reason


def test_aliases_reported_for_near_collinear_terms():
    prob = _problem({"const": 0.5}, seed=6)
    n_eff = N / reg.correlation_time(_noise(106))
    s = sel.forward_select(prob, n_eff=n_eff)
    assert s.selected[0] in ("const", "twin")
    other = "twin" if s.selected[0] == "const" else "const"
    aliases = sel.find_aliases(prob, s.selected, s.selected[0], list(prob.candidates), n_eff)
    assert other in aliases
    assert "quad" not in aliases


def test_generic_periodic_basis_beats_the_catalog_only_on_a_periodic_disturbance():
    periodic = _problem({}, seed=7)
    base = periodic.target
    push = 0.8 * np.sin(2 * np.pi * 0.55 * T + 0.4)
    prob_push = reg.Problem(lambda h: base(h) + push, periodic.candidates, T, periodic.bounds)
    a, b = sel.generic_gain(prob_push, (), sel.sinusoid_basis(T))
    assert b / a < 0.5           # the periodic basis removes more than half
    a0, b0 = sel.generic_gain(periodic, (), sel.sinusoid_basis(T))
    assert b0 / a0 > 0.85        # and under 15 % of a catalog-only residual


def test_problem_rejects_bad_shapes_naming_the_argument():
    with pytest.raises(ValueError, match="candidate 'x'"):
        reg.Problem(lambda h: np.zeros(N), {"x": np.ones(N - 1)}, T, (0.2, 1.0))
    with pytest.raises(ValueError, match="bounds"):
        reg.Problem(lambda h: np.zeros(N), {}, T, (1.0, 0.2))
    with pytest.raises(ValueError, match="unknown candidate"):
        reg.fit_set(reg.Problem(lambda h: np.zeros(N), {}, T, (0.2, 1.0)), ("nope",))


def _masking_problem(seed: int, both: bool = True):
    """Two terms that hide each other: X1 = u + εv, X2 = u (ε = 0.1), y = 10·(X1 − X2) = v
    (when ``both``): alone each explains about ε² of y; together, all of it."""
    speed, lean = _signals(seed)
    u, v = speed - speed.mean(), np.gradient(lean, T)
    v = v / v.std()
    u = u / u.std()
    cands = {"a": u + 0.1 * v, "b": u, "const": np.ones(N)}
    e = _noise(seed + 100, 0.2)
    signal = 10.0 * (cands["a"] - cands["b"]) if both else 0.0

    def target(h):
        return (h - 0.6) * 30.0 * lean + signal + e

    return reg.Problem(target, cands, T, (0.2, 1.2))


def test_pair_step_finds_two_terms_that_mask_each_other_and_not_on_a_null():
    p = _masking_problem(3)
    plain = sel.forward_select(p, n_eff=100.0)
    assert plain.selected == ()              # forward steps alone: neither term earns its place
    joint = sel.forward_select(p, n_eff=100.0, pairs=True)
    assert set(joint.selected) == {"a", "b"}
    assert joint.fit.theta["a"][0] == pytest.approx(10.0, rel=0.05)
    assert joint.fit.theta["b"][0] == pytest.approx(-10.0, rel=0.05)
    assert "pair" in joint.history[1].reason
    for seed in range(4):                    # the same candidates, no effect: nothing
        assert sel.forward_select(_masking_problem(seed, both=False), n_eff=100.0, pairs=True).selected == ()


def test_backward_step_drops_a_member_the_later_ones_made_redundant():
    """y = 3(u + v): the blend u + v + 0.6w enters first (it alone explains most of y); u or v
    alone adds little beside it, together they explain y (the pair step), and the blend,
    then redundant, is dropped (the backward step); plain forward selection stops at it."""
    speed, lean = _signals(5)
    unit = [x / x.std() for x in (speed - speed.mean(), np.gradient(lean, T), np.sin(2 * np.pi * T / 7.7))]
    u, v, w = unit[0], unit[1] - unit[0] * (unit[0] @ unit[1]) / (unit[0] @ unit[0]), unit[2]
    cands = {"blend": u + v + 0.6 * w, "u": u, "v": v}
    e = _noise(105, 0.2)

    def target(h):
        return (h - 0.6) * 30.0 * lean + 3.0 * (u + v) + e

    p = reg.Problem(target, cands, T, (0.2, 1.2))
    plain = sel.forward_select(p, n_eff=100.0)
    assert plain.selected == ("blend",)
    s = sel.forward_select(p, n_eff=100.0, pairs=True)
    assert set(s.selected) == {"u", "v"}
    assert any(st.chosen == "blend" and st.reason.startswith("dropped") for st in s.history)
    assert s.fit.theta["u"][0] == pytest.approx(3.0, rel=0.05)


def test_project_out_tests_candidates_beside_a_structure():
    """A large sinusoid that no candidate explains hides a small constant term; beside the
    sinusoid's columns the constant is found, with its value."""
    speed, lean = _signals(7)
    sine = 5.0 * np.sin(2 * np.pi * 0.45 * T + 0.3)
    cands = {"const": np.ones(N), "quad": speed * np.abs(speed)}
    e = _noise(107, 0.2)

    def target(h):
        return (h - 0.6) * 30.0 * lean + 0.3 * cands["const"] + sine + e

    p = reg.Problem(target, cands, T, (0.2, 1.2))
    P = np.column_stack([np.sin(2 * np.pi * 0.45 * T), np.cos(2 * np.pi * 0.45 * T)])
    beside = sel.forward_select(sel.project_out(p, P), n_eff=100.0, pairs=True)
    assert beside.selected == ("const",)
    assert beside.fit.theta["const"][0] == pytest.approx(0.3, abs=0.05)
    assert sel.project_out(p, None) is p


def test_adaptive_candidate_columns_depend_on_the_set():
    """An adaptive candidate's columns are chosen given the set's other members; frozen()
    fixes them as inside a given set."""
    speed, lean = _signals(2)
    calls = []

    def hook(others):
        calls.append(others)
        col = np.ones(N) if "quad" in others else np.gradient(lean, T)
        return reg.Adapted(col, 1, None)

    p = reg.Problem(lambda h: (h - 0.6) * lean, {"quad": speed * np.abs(speed), "ad": np.zeros(N)}, T,
                    (0.2, 1.2), adaptive={"ad": hook})
    assert np.allclose(p.columns("ad", ("ad", "quad")), 1.0)
    assert np.allclose(p.columns("ad", ("ad",))[:, 0], np.gradient(lean, T))
    assert sel.n_params(p, ("ad", "quad")) == 4          # 2 columns, 1 chosen parameter, h
    f = p.frozen(("quad",))
    assert f.adaptive == {} and np.allclose(f.candidates["ad"], 1.0) and f.shape_params["ad"] == 1
    bad = reg.Problem(lambda h: lean, {"ad": np.zeros(N)}, T, (0.2, 1.2),
                      adaptive={"ad": lambda o: reg.Adapted(np.zeros(N - 1))})
    with pytest.raises(reg.SelectionError, match="'ad'"):
        bad.columns("ad", ("ad",))
