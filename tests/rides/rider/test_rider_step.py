"""The calibrated_rider step's place among the simulated ride's steps (rides/rider/rider_step.py)."""

from euc_sim.rides.rider.rider_step import RIDER_STEPS


def test_calibrated_rider_step_sits_between_the_law_and_the_drivetrain_and_says_why_it_skips():
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.sim_steps import StepInputs, build_steps

    est = {"copper_loss": 0.004}
    steps = build_steps(StepInputs(TABLE3, est, est, ()), RIDER_STEPS)
    assert [s.name for s in steps] == ["nominal", "measured_law", "calibrated_rider", "drivetrain"]
    cal = steps[2]
    assert cal.why is not None and "no fit ride log" in cal.why
    assert steps[3].rider is None and steps[3].plan_window is None   # built on the last step that ran


def test_the_rider_fit_draws_the_requests_replicates_and_seed(monkeypatch):
    """``--n-boot`` and ``--seed`` hold for the calibrated rider's fit too."""
    import euc_sim.rides.rider.rider_step as rider_step
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.sim_steps import StepInputs, build_steps

    seen = []

    def spy(log, **kw):
        seen.append((kw.get("n_boot"), kw.get("seed")))
        raise rider_step.RiderFitError("spied")

    monkeypatch.setattr(rider_step, "fit_rider", spy)
    est = {"copper_loss": 0.004}
    steps = build_steps(StepInputs(TABLE3, est, est, (), fit_log="fit.csv", n_boot=12, seed=7), RIDER_STEPS)
    assert seen == [(12, 7)] and "spied" in steps[2].why
