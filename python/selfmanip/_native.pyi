"""Type stubs for the native module ``selfmanip._native`` (pyo3). The leap/sweep functions are
typed in full; the rest of the module (robot, motor, analysis bindings) is typed loosely via
``__getattr__`` — use the documented Python wrappers in ``selfmanip.*``."""

from os import PathLike
from typing import Any

import numpy as np
import numpy.typing as npt

class SelfmanipError(ValueError): ...
class SingularKktError(SelfmanipError): ...

def leap_sweepable_names() -> list[str]: ...
def leap_defaults_json() -> str: ...
def leap_grammar_text() -> str: ...
def leap_run(
    strategy: str,
    t2_s: float,
    gear_ratio: float | None,
    overrides_json: str,
    dt_s: float | None = None,
) -> dict[str, Any]: ...
def leap_sweep(
    strategies: list[str],
    t2_s: list[float],
    gear_ratio: list[float],
    base_overrides_json: str,
    point_overrides_json: str,
    threads: int,
) -> dict[str, npt.NDArray[np.float64] | npt.NDArray[np.int64] | list[str]]: ...
def leap_write_mcap(
    path: str | PathLike[str],
    params_json: str,
    contacts: list[str],
    t_s: list[float],
    q: npt.NDArray[np.float64],
    qd: npt.NDArray[np.float64],
    mode: list[str],
    contact_points_m: npt.NDArray[np.float64],
    contact_forces_n: npt.NDArray[np.float64],
    events_json: str,
    metadata: dict[str, str],
) -> None: ...
def ground_reaction_complex_json() -> str: ...
def rhex_default_params_json() -> str: ...
def __getattr__(name: str) -> Any: ...
