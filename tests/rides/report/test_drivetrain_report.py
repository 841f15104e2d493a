"""The mass and drivetrain section of the ride page (euc_sim.rides.report.drivetrain_report)."""

from __future__ import annotations

from euc_sim.rides.report.drivetrain_report import _mass_md


def test_the_mass_interval_names_its_parts_without_an_efficiency():
    """The balance has no efficiency; the V9 and Lynx pages still listed 'efficiency model 0.0 kg'
    among the mass interval's parts (the key names the choice of copper-loss column)."""
    tm = {"estimate": 114.0, "ci95": [85.0, 141.0], "speed_scale": 0.913, "speed_scale_source": "gps",
          "lag_s": 0.0, "equivalent_mass": None, "statistical_ci95": [97.0, 127.0],
          "systematic": {"speed_scale": 5.3, "current_scale": 23.2, "efficiency_model": 0.0,
                         "grade": 1.9, "rotating_share": 2.1}}
    md = "\n".join(_mass_md({"total_mass": tm}))
    assert "efficiency" not in md
    assert ("(95 % half-widths: speed scale 5.3 kg, current scale 23.2 kg, copper-loss model (κ·F² or κ·a²) "
            "0.0 kg, grade 1.9 kg, rotating inertia's share 2.1 kg)") in md
