"""The blind total mass, the drivetrain, the PWM, the envelope and the wheel spec.

A twin (:mod:`drivesynth`: a ride synthesised with a known mass and drivetrain)
is recovered; the real rides of ``../shared/data/euc_core`` are read and two are
fitted (skipped when ``../shared`` is absent); bad input gets one line and exit 2.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivesynth import DRIVE, drive_log
from euc_sim.cli import main
from euc_sim.rides.drive.mass import fit_mass
from euc_sim.rides.drive.rotating import ROTATING_SHARE, without_rotating_inertia
from euc_sim.rides.grids.power import MassSettings, RideDataError, power_signals, speed_scale
from euc_sim.report.ride.contract import physics_json
from euc_sim.rides.drive.drivetrain_report import analyse, mass_drivetrain
from euc_sim.rides.source.logs import LogFormatError, read_log
from euc_sim.rides.source.spec import SpecError, read_spec, wheel_spec

SHARED = Path(__file__).resolve().parents[4] / "shared" / "data" / "euc_core"
FAST = MassSettings(n_boot=40)


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    d = tmp_path_factory.mktemp("twin")
    return analyse(read_log(drive_log(d / "twin.csv", seed=3), emit_warnings=False), settings=FAST)


# --- the twin: a ride with known mass and drivetrain ------------------------------------------
def test_twin_total_mass_inside_interval(twin):
    m = twin.mass
    assert m.ci95[0] <= DRIVE["mass"] <= m.ci95[1]
    assert abs(m.estimate / DRIVE["mass"] - 1) < 0.05
    assert m.scale.source == "gps" and m.scale.estimate == pytest.approx(DRIVE["scale"], rel=0.01)
    assert "copper" in m.terms and "rolling" in m.terms
    # the model is complete on the twin: every energy-balance window gives the same mass
    masses = np.array(list(m.by_window.values()))
    assert masses.size == 3 and masses.max() / masses.min() - 1 < 0.02


def test_twin_drivetrain_terms(twin):
    t = twin.drivetrain.terms
    assert t["internal_resistance"].estimate == pytest.approx(DRIVE["R_int"], rel=0.05)
    assert t["ocv_start"].estimate == pytest.approx(DRIVE["E0"], abs=0.2)
    assert t["ocv_per_Ah"].estimate == pytest.approx(DRIVE["k_Q"], rel=0.05)
    assert t["back_emf_per_speed"].estimate == pytest.approx(DRIVE["K_v"], rel=0.02)
    assert t["resistive_drop"].estimate == pytest.approx(DRIVE["r_F"], rel=0.05)
    assert t["winding_resistance"].estimate == pytest.approx(DRIVE["R_w"], rel=0.15)
    c_rr = DRIVE["c1"] / (DRIVE["mass"] * 9.81)
    assert t["C_rr"].estimate == pytest.approx(c_rr, rel=0.15)
    assert t["C_dA"].estimate == pytest.approx(2 * DRIVE["c3"] / 1.2, rel=0.2)


def test_twin_without_gps_widens_the_interval(tmp_path):
    r = analyse(read_log(drive_log(tmp_path / "nogps.csv", seed=3, gps=False), emit_warnings=False), settings=FAST)
    m = r.mass
    assert m.scale.source == "assumed"
    assert "speed_scale" in m.unidentified
    # the wheel reads 1/0.95 of the true speed: uncorrected, m comes out 0.95² as large
    assert m.estimate == pytest.approx(DRIVE["mass"] * DRIVE["scale"] ** 2, rel=0.06)
    assert m.ci95[0] <= DRIVE["mass"] <= m.ci95[1]


def test_twin_without_phase_current_uses_the_proxy(tmp_path):
    r = analyse(read_log(drive_log(tmp_path / "nophase.csv", seed=3, phase=False), emit_warnings=False), settings=FAST)
    assert "winding_resistance" in r.mass.unidentified
    # the a² proxy misses the copper loss's cross term: a bias of a few %, stated in docs
    assert abs(r.mass.estimate / DRIVE["mass"] - 1) < 0.10


def test_unsigned_current_leaves_the_mass_unidentified(tmp_path):
    r = analyse(read_log(drive_log(tmp_path / "unsigned.csv", seed=4, signed=False), emit_warnings=False), settings=FAST)
    assert r.mass.estimate is None and "braking cannot be told from driving" in r.mass.why
    assert "regeneration" in r.mass.unidentified


def test_same_seed_same_interval(tmp_path):
    p = drive_log(tmp_path / "a.csv", seed=5, duration=300.0)
    a, b = fit_mass(read_log(p, emit_warnings=False), FAST), fit_mass(read_log(p, emit_warnings=False), FAST)
    assert a.ci95 == b.ci95


def test_pwm_heldout_and_envelope(tmp_path, twin):
    other = drive_log(tmp_path / "other.csv", seed=8, duration=300.0)
    rep = physics_json(mass_drivetrain(read_log(twin.path, emit_warnings=False),
                                       compare=read_log(other, emit_warnings=False), settings=FAST, fitted=twin))
    assert rep["pwm"]["unit"] == "%" and rep["pwm"]["heldout_rmse"] < 1.0
    assert rep["total_mass"]["ci95"][0] <= DRIVE["mass"] <= rep["total_mass"]["ci95"][1]
    env = rep["envelope"]
    full = np.asarray(env["full"]["accel"], float)
    low = np.asarray(env["low"]["accel"], float)
    ok = np.isfinite(full) & np.isfinite(low)
    fast = np.asarray(env["speed"]) > 10.0
    assert np.all(np.diff(full[np.isfinite(full) & fast]) < 0)    # falls with speed where the back-EMF rules
    assert np.all(low[ok] < full[ok])                               # and with charge
    assert env["low"]["v_limit"] < env["full"]["v_limit"]
    # the twin logs 90 % throughout: 20 cells counted from its voltage, 84 V at 100 %, 66 V at 0 %
    assert (env["full"]["voltage"], env["low"]["voltage"]) == (pytest.approx(84.0), pytest.approx(66.0))


def test_envelope_needs_pwm(twin):
    from dataclasses import replace
    no_pwm = replace(twin, drivetrain=replace(twin.drivetrain, pwm_coef=None))
    md = mass_drivetrain(read_log(twin.path, emit_warnings=False), settings=FAST, fitted=no_pwm)
    assert md.envelope.why.startswith("needs the PWM model") and md.envelope.speed is None


# --- readers: EUC World safety margin, edge cases ----------------------------------------------
def test_safety_margin_is_read_as_pwm(tmp_path):
    p = drive_log(tmp_path / "sm.csv", seed=1, duration=60.0)
    log = read_log(p, emit_warnings=False)
    raw = np.loadtxt(p, delimiter=",", skiprows=1, usecols=6, dtype=str)
    assert "pwm" in log.data and "safety_margin" in log.data
    assert np.allclose(log.data["pwm"], 100.0 - log.data["safety_margin"])
    assert any("100 - safety_margin" in w for w in log.warnings)
    assert raw.size >= len(log.data)


def test_gps_outage_and_altitude_spike(tmp_path):
    p = drive_log(tmp_path / "gps.csv", seed=2, duration=300.0)
    lines = p.read_text().splitlines()
    for i in range(200, 600):                    # a GPS outage: empty cells for 80 s
        f = lines[i].split(",")
        f[10:14] = ["", "", "", ""]
        lines[i] = ",".join(f)
    f = lines[800].split(",")
    if f[13]:
        f[13] = "950.0"                          # one altitude spike
    lines[800] = ",".join(f)
    p.write_text("\n".join(lines) + "\n")
    m = fit_mass(read_log(p, emit_warnings=False), FAST)
    assert m.scale.source == "gps" and m.estimate is not None
    assert m.ci95[0] <= DRIVE["mass"] <= m.ci95[1]


# --- bad input: one line, file and column, exit 2 -----------------------------------------------
def _bad(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text) if isinstance(text, str) else p.write_bytes(text)
    return p


def test_no_current_column(tmp_path):
    p = _bad(tmp_path, "nocur.csv", "datetime,speed,voltage,power\n"
             + "".join(f"2025-07-01T10:00:{k:02d}.000+0200,{10 + k % 5},84,{100 * k}\n"
                       for k in range(50)))
    with pytest.raises(RideDataError, match=r"nocur\.csv: column 'current'"):
        power_signals(read_log(p, emit_warnings=False))


def test_all_zero_speed(tmp_path):
    p = _bad(tmp_path, "still.csv", "datetime,speed,voltage,current\n"
             + "".join(f"2025-07-01T10:00:{k:02d}.000+0200,0.00,84,0.5\n" for k in range(50)))
    with pytest.raises(RideDataError, match=r"still\.csv: column 'speed'"):
        power_signals(read_log(p, emit_warnings=False))


def test_binary_log(tmp_path):
    p = _bad(tmp_path, "bin.csv", bytes(range(256)) * 8)
    with pytest.raises(LogFormatError, match=r"bin\.csv"):
        read_log(p, emit_warnings=False)


def test_spec_missing_weight(tmp_path):
    p = _bad(tmp_path, "spec.csv", "Field|Data\nBrand| X\nWheel diameter| 16 inches\nTension| 84 V\n")
    with pytest.raises(SpecError, match=r"spec\.csv: field 'Net weight'"):
        read_spec(p)


def test_spec_bad_unit_and_binary(tmp_path):
    p = _bad(tmp_path, "unit.csv", "Field|Data\nNet weight| 23 lb\n")
    with pytest.raises(SpecError, match="field 'Net weight': expected the unit 'kg'"):
        read_spec(p)
    q = _bad(tmp_path, "bin.csv", b"\xff\xfe\x00\x81" * 40)
    with pytest.raises(SpecError, match=r"bin\.csv: not a text"):
        read_spec(q)


def test_spec_overrides(tmp_path):
    p = _bad(tmp_path, "v.csv", "Field|Data\nBrand| B\nModel| M\nWheel diameter| 16 inches\n"
                                "Net weight| 23.5 kg\nTension| 84 V\n")
    s = read_spec(p)
    assert (s.radius, s.wheel_mass, s.battery_voltage, s.name) == \
        (pytest.approx(0.2032), 23.5, 84.0, "B M")
    o = wheel_spec(p, wheel_mass=30.0)
    assert o.wheel_mass == 30.0 and o.radius == s.radius and "command line" in o.source
    assert wheel_spec().missing == ("radius", "wheel_mass", "battery_voltage")


@pytest.mark.parametrize("case", ["nocur", "still", "binary", "spec"])
def test_cli_bad_input_exit_2(tmp_path, capsys, case):
    log = drive_log(tmp_path / "ok.csv", seed=1, duration=60.0)
    argv = ["ride", str(log), "--no-simulate", "--n-boot", "10"]
    if case == "nocur":
        argv[1] = str(_bad(tmp_path, "nocur.csv", "datetime,speed,voltage,power\n" + "".join(
            f"2025-07-01T10:00:{k:02d}.000+0200,{10 + k % 5},84,{100 * k}\n" for k in range(50))))
        want = "nocur.csv: column 'current'"
    elif case == "still":
        argv[1] = str(_bad(tmp_path, "still.csv", "datetime,speed,voltage,current\n" + "".join(
            f"2025-07-01T10:00:{k:02d}.000+0200,0.00,84,0.5\n" for k in range(50))))
        want = "still.csv: column 'speed'"
    elif case == "binary":
        argv[1] = str(_bad(tmp_path, "bin.csv", bytes(range(256)) * 8))
        want = "bin.csv"
    else:
        spec = _bad(tmp_path, "spec.csv", "Field|Data\nWheel diameter| 16 inches\n")
        argv += ["--wheel", str(spec)]
        want = "spec.csv: field 'Net weight'"
    code = main(argv)
    err = [ln for ln in capsys.readouterr().err.splitlines()     # progress lines aside
           if ln.strip() and not ln.startswith("ride: ")]
    assert code == 2
    assert len(err) == 1 and want in err[0], err


# --- the real rides ---------------------------------------------------------------------------
REAL = sorted(SHARED.glob("trips/*/*/*/[0-9].csv")) if SHARED.is_dir() else []


@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
@pytest.mark.parametrize("path", REAL, ids=[f"{p.parts[-3]}/{p.parts[-2]}" for p in REAL])
def test_every_real_ride_reads(path):
    log = read_log(path, emit_warnings=False)
    assert log.layout in ("eucworld", "wheellog")
    assert {"voltage", "current"} <= set(log.data.columns)
    assert log.data["v"].max() > 5.0 and log.duration > 600
    if "pwm" in log.data:
        assert 0.0 <= np.nanmedian(log.data["pwm"]) <= 100.0
    if log.layout == "eucworld":
        assert "safety_margin" in log.data            # read as 100 − PWM


@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
def test_every_spec_reads():
    for p in sorted((SHARED / "specs").glob("*.csv")):
        s = read_spec(p)
        assert 8.0 < s.wheel_mass < 60.0 and 0.1 < s.radius < 0.3 and 50 < s.battery_voltage < 200


@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
def test_real_ride_mass_does_not_hang_on_the_window():
    """Blitz 4: the 1 s Savitzky–Golay regression gave 98/122/149 kg at 0.5/1/2 s windows.

    The energy balance over windows filters both sides alike, so the windows
    agree to a few per cent, and the interval (which pools them) holds every
    window's mass and, on this ride, the truth (rider + spec net weight from
    meta.csv).  Accuracy over all rides is the study's, not asserted here
    (V9 ride 2, for one, reads +26 %).
    """
    import csv

    folder = SHARED / "trips/begode/blitz/4"
    with open(folder / "meta.csv") as fh:
        truth = float(next(csv.DictReader(fh))["rider_weight"]) + read_spec(SHARED / "specs/blitz.csv").wheel_mass
    m = fit_mass(read_log(folder / "4.csv", emit_warnings=False), FAST)
    masses = np.array(list(m.by_window.values()))
    assert sorted(m.by_window) == [2.0, 4.0, 8.0]
    assert masses.max() / masses.min() - 1 < 0.10
    assert all(m.ci95[0] < x < m.ci95[1] for x in masses)
    assert m.ci95[0] <= truth <= m.ci95[1]


@pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")
def test_real_unsigned_current_is_said():
    m = fit_mass(read_log(SHARED / "trips/begode/mten4/3/3.csv", emit_warnings=False), MassSettings(n_boot=10))
    assert m.estimate is None and not m.signed and "regeneration" in m.unidentified
    # the app's duty is 6.000·v/V and its current duty × |phase current|: V·I is no battery power
    assert "V·I is not battery power" in m.why and "6.000 V per m/s" in m.unidentified["battery_power"]
    assert speed_scale(read_log(SHARED / "trips/begode/mten4/3/3.csv", emit_warnings=False)).source == "assumed"


def test_rotating_inertia_is_taken_out_of_m_eq_with_a_net_weight(twin):
    # the twin's power balance is driven by m_eq = DRIVE["mass"] (eq. 6); a 30 kg wheel turns
    # 0.19·30 = 5.6 kg of it, so rider + wheel is DRIVE["mass"] - 5.6 kg
    assert "rotating_inertia" in twin.mass.unidentified and not twin.mass.equivalent
    m = without_rotating_inertia(twin.mass, 30.0)
    truth = DRIVE["mass"] - ROTATING_SHARE * 30.0
    assert m.estimate == pytest.approx(twin.mass.estimate - ROTATING_SHARE * 30.0)
    assert m.ci95[0] <= truth <= m.ci95[1]
    assert m.systematic["rotating_share"] == pytest.approx(0.09 * 30.0)
    assert m.ci95[1] - m.ci95[0] > twin.mass.ci95[1] - twin.mass.ci95[0]
    assert m.equivalent["estimate"] == twin.mass.estimate and twin.mass.estimate > m.estimate
    with pytest.raises(ValueError, match="already been taken out"):
        without_rotating_inertia(m, 30.0)


def test_rotating_share_is_table3s():
    assert ROTATING_SHARE == pytest.approx(0.12 / 0.2 ** 2 / 16.0)


def test_no_bootstrap_gives_the_estimate_without_intervals(tmp_path):
    fit = fit_mass(read_log(drive_log(tmp_path / "a.csv", seed=3), emit_warnings=False), MassSettings(n_boot=0))
    assert fit.estimate == pytest.approx(DRIVE["mass"], rel=0.15)
    assert fit.stat_ci95 is None and fit.ci95 is None
    assert all(ci is None for ci in fit.coef_ci95.values())
