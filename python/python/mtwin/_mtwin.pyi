"""Type stubs of the extension module ``mtwin._mtwin`` (the Rust glue; use the ``mtwin``
package's API, which documents every function)."""

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

class MtwinError(Exception): ...
class BadInputError(MtwinError): ...

class Twin:
    def to_json(self) -> str: ...
    def save(self, path: str) -> None: ...
    def guid(self) -> str: ...
    def channels(self) -> Tuple[List[str], List[str], List[str]]: ...
    def eval(self, pose: Sequence[float], f_hz: npt.NDArray[np.float64]) -> Tuple[Dict[str, Any], bool]: ...
    def simulate(
        self, record: Any, hold: str = "zoh"
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], List[str]]: ...
    def refit(
        self,
        records: List[Any],
        *,
        method: str = "time",
        drift_threshold: float = 5.0,
        force: bool = False,
        psd_threshold: Optional[float] = None,
        min_coherence: float = 0.8,
        spread_length: Optional[float] = None,
        command: str = "",
    ) -> Tuple["Twin", str, List[str]]: ...
    def diagnose(self, records: List[Any], *, holdout: float = 0.3) -> Tuple[str, "Twin", List[str]]: ...
    def export_fmu(self, path: str, *, fmi: int = 2, slave: Optional[str] = None) -> Dict[str, int]: ...

def frf(records: List[Any], *, estimator: str = "h1", excitation: str = "auto", nfft: Optional[int] = None) -> Dict[str, Any]: ...
def identify(
    records: List[Any],
    *,
    order: Optional[int] = None,
    fmin: Optional[float] = None,
    fmax: Optional[float] = None,
    estimator: str = "h1",
    excitation: str = "auto",
    pose_tol: float = 1e-3,
    weighting: str = "auto",
    name: str = "machine",
    command: str = "",
) -> Tuple[Twin, List[str]]: ...
def load(path: str) -> Twin: ...
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
) -> Dict[str, Any]: ...
