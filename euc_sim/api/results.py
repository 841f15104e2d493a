"""The public API's typed results: frozen dataclasses whose ``to_json()`` gives the CONTRACT.md
object the matching command writes (a diagnosis keeps its dictionary's key order, byte for byte).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from euc_sim.io import to_jsonable

if TYPE_CHECKING:
    from euc_sim.rides.result import RideResult

__all__ = ["Recording", "Identification", "Diagnosis", "RideAnalysis", "Rendering",
           "Crosscheck", "CrosscheckRow"]


@dataclass(frozen=True, eq=False)
class Recording:
    """A recording (CONTRACT's "A recording"): the table, its sidecar and, for a simulation, its truth.

    Attributes
    ----------
    name : str
        The file stem, or the path read.
    data : pandas.DataFrame
        CONTRACT columns, SI (``t`` s, ``x`` m, ``gamma``, ``phi`` rad, ``M_d``, ``M_h`` N·m, ...).
    meta : mapping
        The ``NAME.json`` sidecar.
    truth : mapping or None
        A simulation's ``NAME.truth.json``; None when read from a file.
    """

    name: str
    data: Any = field(repr=False)
    meta: Mapping[str, Any] = field(default_factory=dict, repr=False)
    truth: Mapping[str, Any] | None = field(default=None, repr=False)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample, s."""
        t = self.data["t"]
        return float(t.iloc[-1] - t.iloc[0]) if len(t) else 0.0

    def to_json(self) -> dict:
        """The sidecar object (``NAME.json``)."""
        return to_jsonable(dict(self.meta))


@dataclass(frozen=True, eq=False)
class Identification:
    """h identified by the 3-DoF and the 2-DoF model (the paper's Section 4).

    Attributes
    ----------
    recordings : tuple of str
    models : mapping of str to HFit
        Pooled: ``"3dof"``, ``"2dof"`` → :class:`~euc_sim.identification.h_fit.HFit` (h, m).
    per_recording : tuple of mapping
        The same per recording.
    """

    recordings: tuple[str, ...]
    models: Mapping[str, Any]
    per_recording: tuple[Mapping[str, Any], ...]

    @property
    def h(self) -> float:
        """The pooled 3-DoF h, m."""
        return float(self.models["3dof"].h)

    def to_json(self) -> dict:
        """CONTRACT's ``euc-sim identify`` object."""
        return to_jsonable({
            "recordings": list(self.recordings),
            "models": {m: f.as_json() for m, f in self.models.items()},
            "per_recording": [{"recording": name, "models": {m: f.as_json() for m, f in fits.items()}}
                              for name, fits in zip(self.recordings, self.per_recording)],
        })


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """What the nominal model leaves out of a recording (CONTRACT's "Diagnosis output").

    Attributes
    ----------
    nominal_rmse, augmented_rmse, noise_floor : float
        Held-out residual RMSE without and with the accepted effects; the measurement noise's, N·m.
    effects : list of dict
        Accepted effects, strongest first (``name``, ``estimate``, ``unit``, ``ci95``, ...).
    unexplained : bool
        Structure remains that no catalogued effect explains.
    windows : list of [float, float]
        Where the mismatch concentrates, s.
    h_nominal, h_augmented : float
        h identified without and with the effects, m.
    tentative : list of dict
        Effects seen but not accepted.
    series : mapping
        The time series behind the report's figures (not in the JSON).
    """

    recording: str
    nominal_rmse: float
    effects: list
    unexplained: bool
    windows: list
    augmented_rmse: float = float("nan")
    h_nominal: float = float("nan")
    h_augmented: float = float("nan")
    noise_floor: float = float("nan")
    verdict: str = ""
    notes: list = field(default_factory=list)
    tentative: list = field(default_factory=list)
    details: Mapping[str, Any] = field(default_factory=dict, repr=False)
    key_order: tuple[str, ...] = field(default=(), repr=False)
    series: Mapping[str, Any] = field(default_factory=dict, repr=False)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], series: Mapping[str, Any]) -> Diagnosis:
        """The result of the pipeline's dictionary ``d``: its public keys (not starting with ``_``) as fields, the
        rest in :attr:`details`, their order in :attr:`key_order`; ``series`` never reaches the JSON."""
        names = {f.name for f in dataclasses.fields(cls)} - {"details", "key_order"}
        public = [k for k in d if not k.startswith("_")]
        return cls(**{k: d[k] for k in public if k in names}, details={k: d[k] for k in public if k not in names},
                   key_order=tuple(public), series=series)

    def _public(self) -> dict:
        """The pipeline's public keys, in its order."""
        return {k: self.details[k] if k in self.details else getattr(self, k) for k in self.key_order}

    def to_json(self) -> dict:
        """CONTRACT's ``euc-sim diagnose`` object, keys in the pipeline's order."""
        return to_jsonable(self._public())

    def as_result(self) -> dict:
        """The pipeline's dictionary (series under ``_series``), for :mod:`euc_sim.report.diagnosis`."""
        return {**self._public(), "_series": dict(self.series)}

    def summary(self) -> str:
        """The diagnosis as ``euc-sim diagnose`` prints it."""
        from euc_sim.report.diagnosis import summary  # deferred: loads plotly (0.03 s)

        return summary(self.as_result())

    def write_report(self, folder) -> Path:
        """Write ``index.html``, ``index.md`` and the figures to ``folder``; returns ``index.md``."""
        from euc_sim.report.diagnosis import write_report  # deferred: loads plotly (0.03 s)

        return write_report(self.as_result(), folder)


@dataclass(frozen=True, eq=False)
class RideAnalysis:
    """What ``euc-sim ride`` finds: the typed :class:`~euc_sim.rides.result.RideResult` and the report's ``files`` (or None)."""

    result: RideResult = field(repr=False)
    files: Any = None

    effects = property(lambda self: tuple(self.result.balance.cross.accepted),
                       doc="Names of the accepted physics the nominal (inertia-only) model lacks, in the order kept.")
    heldout_error_nominal = property(lambda self: self.result.balance.cross.heldout_nominal,
                                     doc="Held-out error without the effects, in :attr:`error_unit`.")
    heldout_error_augmented = property(lambda self: self.result.balance.cross.heldout_augmented,
                                       doc="Held-out error with the effects, in :attr:`error_unit`.")
    error_unit = property(lambda self: self.result.balance.error_unit, doc='``"W"`` or ``"N·m"``.')
    parameters = property(lambda self: self.result.parameters,
                          doc="Every fitted quantity once (:class:`~euc_sim.rides.balance.parameters.Parameter`).")
    total_mass = property(lambda self: self.result.mass.mass,
                          doc="Rider plus wheel, kg (:class:`~euc_sim.rides.drive.mass.MassFit`).")
    summary = property(lambda self: self.result.rider.summary,
                       doc="The ride as a rider reads it (:class:`~euc_sim.rides.summary.summary.RideSummary`).")

    def to_json(self) -> dict:
        """CONTRACT's ``euc-sim ride`` object."""
        from euc_sim.report.ride.contract import ride_json  # deferred: loads scipy (1.1 s)

        return to_jsonable(ride_json(self.result, self.files))


@dataclass(frozen=True)
class Rendering:
    """A recording replayed in the 3-D model: the file written, frames, fps (1/s), width and height (pixels)."""

    path: str
    frames: int
    fps: float
    width: int
    height: int

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class CrosscheckRow:
    """One cross-check: the worst error found and its bound (same unit)."""

    name: str
    value: float
    bound: float
    ok: bool
    detail: str = ""


@dataclass(frozen=True)
class Crosscheck:
    """The MuJoCo model checked against equations (5)-(8): ``ok`` when every bound holds."""

    ok: bool
    checks: tuple[CrosscheckRow, ...]

    def to_json(self) -> dict:
        """CONTRACT's ``euc-sim crosscheck`` object."""
        return to_jsonable({"ok": self.ok, "checks": [
            {"name": c.name, "value": c.value, "bound": c.bound, "detail": c.detail, "ok": c.ok}
            for c in self.checks]})
