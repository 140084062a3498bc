"""mtwin — machine-tool dynamics twins from Python: numpy in, numpy out.

The same library as the ``mtwin`` command line (Rust, the ``identify`` and ``mtwin-fmu``
crates), so the same numbers::

    import numpy as np, mtwin
    est = mtwin.frf(t, force, response, kind="acceleration")   # est.f_hz, est.h, est.coherence
    twin = mtwin.identify(["impact_x.csv", "impact_y.csv"], fmax=2500)
    h = twin.eval([0.2, 0.1, 0.0], np.linspace(50, 2000, 500)).h
    y = twin.simulate(t, force, poses=[0.2, 0.1, 0.0])
    twin2 = twin.refit(["cut1.csv"])            # twin2.report, twin2.history
    twin2.export_fmu("machine.fmu"); twin2.save("twin2.json")
    mtwin.load("twin2.json")

Records are time-series CSV paths (docs/formats.md, "Time-series CSV") or dicts of 1-D
float arrays named as that format's columns (``t``, ``fx``, ``dx`` or ``ax``, ``x``, ...;
:func:`record` builds one). Every error is a :class:`MtwinError` (:class:`BadInputError`
for unusable input) with the command line's message; arrays of the wrong dtype raise
``TypeError``, of the wrong shape ``ValueError``. The numerical work runs without the GIL.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _mtwin
from ._mtwin import BadInputError, MtwinError

__all__ = [
    "BadInputError",
    "Diagnosis",
    "FRF",
    "Lobes",
    "MtwinError",
    "Twin",
    "frf",
    "frf_records",
    "identify",
    "load",
    "lobes",
    "record",
]
__version__ = "0.1.0"

PathLike = Union[str, "os.PathLike[str]"]
Record = Union[PathLike, Mapping[str, np.ndarray]]

_AXES = "xyz"


def _f64(name: str, x: Any, ndim: Optional[Tuple[int, ...]] = None) -> np.ndarray:
    """`x` as a float64 array (integers and float32 converted); other dtypes raise TypeError,
    another number of dimensions than `ndim` ValueError."""
    a = np.asarray(x)
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name}: expected real numbers (float64), got dtype {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if ndim is not None and a.ndim not in ndim:
        raise ValueError(f"{name}: expected {' or '.join(f'{d}-D' for d in ndim)} array, got shape {a.shape}")
    return a


def _axes(name: str, axes: Optional[str], k: int) -> str:
    axes = _AXES[:k] if axes is None else axes.lower()
    if len(axes) != k or any(a not in _AXES for a in axes) or len(set(axes)) != k:
        raise ValueError(f"{name}: {axes!r} does not name {k} distinct axes of x, y, z")
    return axes


def _columns(prefix: str, name: str, data: Any, axes: Optional[str], n: int) -> Dict[str, np.ndarray]:
    a = _f64(name, data, (1, 2))
    if a.ndim == 1:
        a = a[:, None]
    if a.shape[0] != n:
        raise ValueError(f"{name}: {a.shape[0]} samples, but t has {n}")
    ax = _axes(name + " axes", axes, a.shape[1])
    return {prefix + c: a[:, j].copy() for j, c in enumerate(ax)}


def record(
    t: Any,
    force: Any,
    response: Any = None,
    *,
    inputs: Optional[str] = None,
    outputs: Optional[str] = None,
    kind: str = "displacement",
    poses: Any = None,
) -> Dict[str, np.ndarray]:
    """A record as the dict of columns of a time-series CSV.

    ``t`` (n,) sample times in s (uniform); ``force`` (n,) or (n, k) in N along ``inputs``
    (default ``"x"``, ``"xy"``, ...); ``response`` (n,) or (n, m) along ``outputs``, in m
    (``kind="displacement"``) or m/s² (``kind="acceleration"``); ``poses`` (3,) or (n, 3)
    axis positions in m.
    """
    tt = _f64("t", t, (1,))
    n = tt.shape[0]
    cols: Dict[str, np.ndarray] = {"t": tt}
    cols.update(_columns("f", "force", force, inputs, n))
    if response is not None:
        if kind not in ("displacement", "acceleration"):
            raise ValueError(f"kind {kind!r}: use 'displacement' or 'acceleration'")
        cols.update(_columns("d" if kind == "displacement" else "a", "response", response, outputs, n))
    if poses is not None:
        p = _f64("poses", poses, (1, 2))
        if p.ndim == 1:
            if p.shape != (3,):
                raise ValueError(f"poses: expected (3,) or (n, 3), got shape {p.shape}")
            p = np.broadcast_to(p, (n, 3))
        if p.shape != (n, 3):
            raise ValueError(f"poses: expected (3,) or ({n}, 3), got shape {p.shape}")
        for j, c in enumerate(_AXES):
            cols[c] = np.ascontiguousarray(p[:, j])
    return cols


@dataclass(frozen=True)
class FRF:
    """A frequency response (receptance, m/N).

    ``h[k, o, i]`` is the response along ``outputs[o]`` to a force along ``inputs[i]`` at
    ``f_hz[k]``; ``coherence`` likewise (NaN where not measured or not defined).
    """

    f_hz: np.ndarray
    h: np.ndarray
    coherence: np.ndarray
    outputs: List[str]
    inputs: List[str]
    method: str = ""
    df_hz: float = float("nan")
    averages: int = 0
    warnings: List[str] = field(default_factory=list)


def _frf(d: Mapping[str, Any]) -> FRF:
    return FRF(
        f_hz=d["f_hz"],
        h=d["h"],
        coherence=d["coherence"],
        outputs=list(d["outputs"]),
        inputs=list(d["inputs"]),
        method=d.get("method", ""),
        df_hz=d.get("df_hz", float("nan")),
        averages=d.get("averages", 0),
        warnings=list(d.get("warnings", [])),
    )


def frf_records(
    records: Union[Record, Iterable[Record]],
    *,
    estimator: str = "h1",
    excitation: str = "auto",
    nfft: Optional[int] = None,
) -> FRF:
    """FRF estimate of records (paths or dicts), as ``mtwin frf``: records with the same
    excitation direction are averaged. ``estimator``: h1, h2 or hv; ``excitation``: auto,
    impact, continuous or chirp; ``nfft``: Welch segment length."""
    return _frf(_mtwin.frf(_recs(records), estimator=estimator, excitation=excitation, nfft=nfft))


def frf(
    t: Any,
    force: Any,
    response: Any,
    *,
    inputs: Optional[str] = None,
    outputs: Optional[str] = None,
    kind: str = "displacement",
    estimator: str = "h1",
    excitation: str = "auto",
    nfft: Optional[int] = None,
) -> FRF:
    """FRF estimate (receptance m/N, with coherence) of one record given as arrays; see
    :func:`record` for the arrays and :func:`frf_records` for the options. An
    acceleration response (``kind="acceleration"``) is integrated to receptance, as the
    command line does."""
    rec = record(t, force, response, inputs=inputs, outputs=outputs, kind=kind)
    return frf_records([rec], estimator=estimator, excitation=excitation, nfft=nfft)


def _recs(records: Union[Record, Iterable[Record]]) -> List[Any]:
    if isinstance(records, (str, os.PathLike, Mapping)):
        records = [records]
    out: List[Any] = []
    for r in records:
        if isinstance(r, Mapping):
            out.append({str(k): _f64(f"column {k!r}", v, (1,)) for k, v in r.items()})
        elif isinstance(r, os.PathLike):
            out.append(os.fspath(r))
        else:
            out.append(r)
    return out


def _slave() -> Optional[str]:
    """The FMU slave library the wheel ships, if it does."""
    try:
        p = resources.files("mtwin") / "libmtwin_fmu.so"
        return str(p) if p.is_file() else None
    except (OSError, TypeError):
        return None


class Twin:
    """A machine's dynamics twin: pose models, interpolation, history (the twin file of the
    command line, docs/formats.md). Build it with :func:`identify` or :func:`load`."""

    def __init__(self, native: "_mtwin.Twin", warnings: Sequence[str] = (), report: Optional[Dict[str, Any]] = None):
        self._t = native
        #: warnings of the operation that made this twin (FRF estimation, fit, reader)
        self.warnings: List[str] = list(warnings)
        #: the refit report (drift check, modes changed) when made by :meth:`refit`
        self.report: Optional[Dict[str, Any]] = report
        self._info: Optional[Dict[str, Any]] = None

    def __repr__(self) -> str:
        return repr(self._t)

    @property
    def info(self) -> Dict[str, Any]:
        """The whole twin file as a dict (poses, models, fits, plans, history)."""
        if self._info is None:
            self._info = json.loads(self._t.to_json())
        return self._info

    @property
    def name(self) -> str:
        return self.info["name"]

    @property
    def poses(self) -> np.ndarray:
        """Measured poses (p, 3) in m."""
        return np.array([p["pose"] for p in self.info["poses"]], dtype=float)

    @property
    def history(self) -> List[Dict[str, Any]]:
        """The lifetime history (one entry per identification and refit)."""
        return list(self.info.get("history", []))

    @property
    def channels(self) -> List[str]:
        """Channel names, ``"xy"`` = response x to force y."""
        return self._t.channels()[0]

    @property
    def outputs(self) -> List[str]:
        return self._t.channels()[1]

    @property
    def inputs(self) -> List[str]:
        return self._t.channels()[2]

    @property
    def guid(self) -> str:
        """The GUID (FMI 2) / instantiation token (FMI 3) of this twin's FMU."""
        return self._t.guid()

    def to_json(self) -> str:
        """The twin file's JSON text."""
        return self._t.to_json()

    def save(self, path: PathLike) -> None:
        """Writes the twin file (atomically; the command line's schema)."""
        self._t.save(os.fspath(path))

    def eval(self, pose: Sequence[float], f_hz: Any) -> FRF:
        """The receptance at ``pose`` (X, Y, Z in m) for the frequencies ``f_hz`` (Hz), as
        ``mtwin eval``: interpolated between measured poses; outside the measured box the
        model of its nearest point (``FRF.warnings`` says so)."""
        d, inside = self._t.eval(_f64("pose", pose, (1,)).tolist(), _f64("f_hz", f_hz, (1,)))
        out = _frf(d)
        if not inside:
            out.warnings.append(f"pose {list(pose)} is outside the measured box: the model of its nearest point is used")
        return out

    def simulate(
        self,
        t: Any,
        force: Any,
        poses: Any = None,
        *,
        inputs: Optional[str] = None,
        hold: str = "zoh",
    ) -> np.ndarray:
        """Predicted TCP displacement (n, len(outputs)) in m, columns :attr:`outputs`, for
        forces ``force`` (n,) or (n, k) in N along ``inputs`` (default: the twin's inputs)
        at ``poses`` (3,) or (n, 3), as ``mtwin simulate``. ``hold``: zoh (what the FMU
        does), foh or band."""
        f = _f64("force", force, (1, 2))
        k = 1 if f.ndim == 1 else f.shape[1]
        if inputs is None:
            inputs = "".join(self.inputs)[:k] if k <= len(self.inputs) else None
        rec = record(t, f, inputs=inputs, poses=poses)
        return self.simulate_record(rec, hold=hold)[1]

    def simulate_record(self, rec: Record, *, hold: str = "zoh") -> Tuple[np.ndarray, np.ndarray]:
        """Times and predicted displacement (n, len(outputs)) for a record (path or dict)."""
        (r,) = _recs([rec])
        tt, y, outs = self._t.simulate(r, hold)
        return tt, y[:, [_AXES.index(a) for a in outs]]

    def refit(
        self,
        records: Union[Record, Iterable[Record]],
        *,
        method: str = "time",
        drift_threshold: float = 5.0,
        force: bool = False,
        psd_threshold: Optional[float] = None,
        min_coherence: float = 0.8,
        spread_length: Optional[float] = None,
    ) -> "Twin":
        """The lifetime update from operating records, as ``mtwin refit``: a new twin with
        the whole history (this one is unchanged); its :attr:`report` holds the drift check
        (``updated``, ``drift_fit_pct``, ...) and the modes changed."""
        t, rep, warnings = self._t.refit(
            _recs(records),
            method=method,
            drift_threshold=drift_threshold,
            force=force,
            psd_threshold=psd_threshold,
            min_coherence=min_coherence,
            spread_length=spread_length,
            command="mtwin.Twin.refit (Python)",
        )
        return Twin(t, warnings, json.loads(rep))

    def diagnose(self, records: Union[Record, Iterable[Record]], *, holdout: float = 0.3) -> "Diagnosis":
        """What the twin gets wrong on measured records, as ``mtwin diagnose``: the named
        cause, the extended twin and the gain on held-out data."""
        d, ext, warnings = self._t.diagnose(_recs(records), holdout=holdout)
        return Diagnosis(json.loads(d), Twin(ext, warnings))

    def export_fmu(self, path: PathLike, *, fmi: int = 2) -> Dict[str, int]:
        """Writes the twin's co-simulation FMU (FMI 2.0, or 3.0 with ``fmi=3``) atomically,
        as ``mtwin export``; returns its sizes in bytes."""
        return self._t.export_fmu(os.fspath(path), fmi=fmi, slave=_slave())

    def lobes(self, pose: Sequence[float], **kw: Any) -> "Lobes":
        """Stability lobes at ``pose``; see :func:`lobes`."""
        return lobes(self, pose, **kw)


@dataclass(frozen=True)
class Diagnosis:
    """A diagnosis: ``result`` (cause, summary, fits before/after, evidence: the
    command line's diagnosis.json) and the ``extended`` twin."""

    result: Dict[str, Any]
    extended: Twin

    @property
    def cause(self) -> str:
        return self.result["cause"]


@dataclass(frozen=True)
class Lobes:
    """Stability lobes: per method (``zoa`` zero-order, ``sd`` semi-discretisation) the
    spindle speeds (rpm), the limiting axial depth (m, inf = no chatter) and the chatter
    frequency (Hz)."""

    zoa_rpm: np.ndarray
    zoa_ap_lim_m: np.ndarray
    zoa_chatter_hz: np.ndarray
    sd_rpm: np.ndarray
    sd_ap_lim_m: np.ndarray
    sd_chatter_hz: np.ndarray
    rigid_channels: List[str]


def lobes(
    twin: Twin,
    pose: Sequence[float],
    *,
    teeth: int = 2,
    diameter: float = 0.016,
    helix: float = 0.0,
    immersion: float = 1.0,
    up: bool = False,
    kt: float = 6e8,
    kr: float = 0.3,
    rpm_min: float = 2000.0,
    rpm_max: float = 20000.0,
    speeds: int = 200,
    sd_speeds: Optional[int] = None,
    sd_steps: int = 40,
) -> Lobes:
    """Milling stability lobes from the twin's tool-tip FRF at ``pose``, as ``mtwin lobes``
    (same options and defaults): zero-order (Altintas–Budak) at ``speeds`` log-spaced
    speeds, semi-discretisation (Insperger–Stépán) at ``sd_speeds`` (default the same; 0:
    none). A missing xx or yy channel is taken as rigid (``rigid_channels``)."""
    d = _mtwin.lobes(
        twin._t,
        _f64("pose", pose, (1,)).tolist(),
        teeth=teeth,
        diameter=diameter,
        helix=helix,
        immersion=immersion,
        up=up,
        kt=kt,
        kr=kr,
        rpm_min=rpm_min,
        rpm_max=rpm_max,
        speeds=speeds,
        sd_speeds=sd_speeds,
        sd_steps=sd_steps,
    )
    z, s = d["zoa"], d["sd"]
    return Lobes(z["rpm"], z["ap_lim_m"], z["chatter_hz"], s["rpm"], s["ap_lim_m"], s["chatter_hz"], list(d["rigid_channels"]))


def identify(
    records: Union[Record, Iterable[Record]],
    *,
    order: Optional[int] = None,
    fmin: Optional[float] = None,
    fmax: Optional[float] = None,
    estimator: str = "h1",
    excitation: str = "auto",
    pose_tol: float = 1e-3,
    weighting: str = "auto",
    name: str = "machine",
) -> Twin:
    """The a-priori twin from a measurement campaign (records grouped by pose and
    excitation axis), as ``mtwin identify`` with the same options: ``order`` modes (default
    from the stabilization diagram), the band ``fmin``..``fmax`` Hz, ``weighting`` auto,
    coherence, ml, balanced or mobility. The warnings are in :attr:`Twin.warnings`."""
    t, warnings = _mtwin.identify(
        _recs(records),
        order=order,
        fmin=fmin,
        fmax=fmax,
        estimator=estimator,
        excitation=excitation,
        pose_tol=pose_tol,
        weighting=weighting,
        name=name,
        command="mtwin.identify (Python)",
    )
    return Twin(t, warnings)


def load(path: PathLike) -> Twin:
    """Reads a twin file written by the command line or :meth:`Twin.save`."""
    return Twin(_mtwin.load(os.fspath(path)))
