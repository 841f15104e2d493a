"""The mass and drivetrain section of the ride page and its figures (euc_sim.report.ride.drivetrain_page)."""

from __future__ import annotations

from dataclasses import replace

from euc_sim.rides.drive.drivetrain import Term
from euc_sim.rides.drive.grade import grade_profile
from euc_sim.rides.drive.mass import MassFit
from euc_sim.io import save_figure
from euc_sim.report.ride.drivetrain_page import _mass_md, grade_figure
from tests.rides.drive.test_grade import _ride
from tests.rides.typed_ride import mass_fit


def _terms(**estimates) -> dict:
    return {k: Term(x, None, None) for k, x in estimates.items()}


def test_the_mass_interval_names_its_parts_without_an_efficiency(ride_result):
    """The balance has no efficiency; the V9 and Lynx pages still listed 'efficiency model 0.0 kg'
    among the mass interval's parts (the key names the choice of copper-loss column)."""
    from euc_sim.rides.grids.power import SpeedScale

    m = mass_fit(114.0, (85.0, 141.0), scale=SpeedScale(0.913, 0.01, "gps"), stat_ci95=(97.0, 127.0),
                 systematic={"speed_scale": 5.3, "current_scale": 23.2, "efficiency_model": 0.0,
                             "grade": 1.9, "rotating_share": 2.1})
    md = "\n".join(_mass_md(replace(ride_result, mass=replace(ride_result.mass, mass=m))))
    assert "efficiency" not in md
    assert ("(95 % half-widths: speed scale 5.3 kg, current scale 23.2 kg, copper-loss model (κ·F² or κ·a²) "
            "0.0 kg, grade 1.9 kg, rotating inertia's share 2.1 kg)") in md


def test_the_mass_fits_own_terms_are_said_apart_from_the_balance_model():
    """Lynx pages showed winding_resistance 0.44 ohm and phase_resistance_pwm 0.074 ohm, and V9
    pages a grade ratio of 0.44 beside the balance's GPS gain 0.56, without saying which is which."""
    from euc_sim.report.ride.drivetrain_page import _nuisance_note

    both = " ".join(_nuisance_note(_terms(winding_resistance=0.44, phase_resistance_pwm=0.074, grade_mass=50.0)))
    assert ("winding_resistance and grade_mass are the mass fit's own terms (how its energy balance "
            "holds the copper loss and the climb") in both
    one = " ".join(_nuisance_note(_terms(copper_loss_per_force2=0.01)))
    assert "copper_loss_per_force2 is the mass fit's own term" in one and "climb" not in one
    assert "need not agree" in both
    assert _nuisance_note(_terms(speed_scale=1.0)) == []
    alone = " ".join(_nuisance_note(_terms(phase_resistance_pwm=0.074)))
    assert alone == ""


def test_grade_figure_is_written(tmp_path):
    sig, fit, t, h = _ride(gps_noise=1.0)
    fit = MassFit(**{**fit.__dict__, "coef": {**fit.coef, "grade": 80.0}})
    g = grade_profile(sig, fit, t, h)
    assert g.fitted is not None
    out = save_figure(grade_figure(g), tmp_path / "grade.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
