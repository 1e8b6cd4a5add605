"""Type stubs of the isowrench Python module (issue 15). Angles rad, lengths m, forces N,
moments N m. See docs/python.md."""

from typing import (Any, Callable, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union,
                    overload)

import numpy as np
import numpy.typing as npt

__version__: str
STATUS_NAMES: Tuple[str, str, str, str]

Posture = Union[None, Sequence[float], npt.NDArray[np.float64], Mapping[str, float]]
Transducer = Union[None, str, Sequence[float], npt.NDArray[np.float64]]
Released = Union[None, str, Sequence[str]]
Locked = Union[None, str, Sequence[str]]

class Wrench:
    """One muscle at one posture: the Eq. 10 wrench and the statics behind it."""
    @property
    def transducer(self) -> npt.NDArray[np.float64]: ...  # (6,) fx fy fz mx my mz, transducer axes
    @property
    def world(self) -> npt.NDArray[np.float64]: ...  # (6,) world axes
    @property
    def classic(self) -> npt.NDArray[np.float64]: ...  # (6,) J^-T tau or pinv(J^T) tau
    @property
    def dtheta(self) -> npt.NDArray[np.float64]: ...  # (n,) rad / m; NaN without equilibrium
    @property
    def equilibrium(self) -> bool: ...
    @property
    def locked(self) -> List[str]: ...
    @property
    def tau(self) -> npt.NDArray[np.float64]: ...  # (n,) N m / N
    @property
    def q(self) -> npt.NDArray[np.float64]: ...  # (n,) rad / m
    @property
    def jacobian(self) -> npt.NDArray[np.float64]: ...  # (6, n) transducer axes
    @property
    def status(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def small_motion(self) -> bool: ...
    @property
    def small_motion_message(self) -> str: ...
    @property
    def muscle(self) -> str: ...
    @property
    def muscle_force_N(self) -> float: ...
    @property
    def muscle_length_m(self) -> float: ...
    @property
    def force(self) -> Dict[str, Any]: ...  # the force stage (model, force_n, active/passive parts)
    @property
    def passive_force(self) -> Dict[str, Any]: ...  # the force stage at activation 0
    @property
    def passive(self) -> npt.NDArray[np.float64]: ...  # (6,) the wrench at activation 0
    @property
    def coordinates(self) -> List[str]: ...

class Model:
    """An immutable limb model; create it with isowrench.load()."""
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def coordinates(self) -> List[str]: ...
    @property
    def coordinate_types(self) -> List[str]: ...
    @property
    def muscles(self) -> List[str]: ...
    @property
    def default_posture(self) -> npt.NDArray[np.float64]: ...
    @property
    def joint_stiffness(self) -> npt.NDArray[np.float64]: ...
    @property
    def transducer_stiffness(self) -> npt.NDArray[np.float64]: ...
    @property
    def released(self) -> List[str]: ...
    @property
    def leg_length_m(self) -> float: ...
    @property
    def locked(self) -> List[str]: ...
    @property
    def wrap(self) -> Literal["opensim", "exact"]: ...
    def kinematics(self, q: Posture = None, activation: float = 1.0,
                   wrap_modes: bool = True) -> Dict[str, Any]: ...
    def wrench(self, muscle: str, q: Posture = None, transducer: Transducer = None,
               released: Released = None, activation: float = 1.0,
               locked: Locked = None) -> Wrench: ...
    @overload
    def wrench_batch(self, muscle: str, Q: npt.ArrayLike, activation: float = 1.0,
                     transducer: Transducer = None, released: Released = None, threads: int = 0,
                     return_status: bool = False, locked: Locked = None) -> npt.NDArray[np.float64]: ...
    @overload
    def wrench_batch(self, muscle: str, Q: npt.ArrayLike, activation: float = 1.0,
                     transducer: Transducer = None, released: Released = None, threads: int = 0,
                     *, return_status: bool, locked: Locked = None) -> Union[npt.NDArray[np.float64],
                                                      Tuple[npt.NDArray[np.float64], npt.NDArray[np.uint8]]]: ...
    def releases(self, muscle: str, q: Posture = None, transducer: Transducer = None,
                 released: Released = None, locked: Locked = None) -> Dict[str, Any]: ...
    def with_overrides(self, released: Released = None, transducer: Transducer = None,
                       base_stiffness: Optional[float] = None,
                       joint_stiffness: Dict[str, float] = ...,
                       locked: Locked = None,
                       wrap: Optional[Literal["opensim", "exact"]] = None,
                       force_model: Optional[str] = None) -> "Model": ...
    def diagnose(self, muscle: str, q: Posture = None, large_deflection: bool = True,
                 transducer: Transducer = None, released: Released = None,
                 locked: Locked = None) -> Dict[str, Any]: ...
    def uncertainty(self, muscle: Optional[str] = None,
                    inputs: Optional[Sequence[Union[str, Mapping[str, Any]]]] = None,
                    spec: Optional[Union[str, Mapping[str, Any]]] = None,
                    from_fit: Optional[str] = None, q: Posture = None,
                    postures: Optional[npt.ArrayLike] = None, samples: int = 4096, seed: int = 1,
                    sobol: bool = True, threads: int = 0, activation: float = 1.0,
                    exact_percentile_values: float = 2e7, max_endpoint_fraction: float = 0.001,
                    max_joint_rotation: float = 0.01,
                    rank_tolerance: float = 1e-12) -> Dict[str, Any]: ...
    @property
    def urdf_text(self) -> str: ...
    def uncertainty_spec(self, inputs: Optional[Sequence[Union[str, Mapping[str, Any]]]] = None,
                         spec: Optional[Union[str, Mapping[str, Any]]] = None,
                         from_fit: Optional[str] = None) -> str: ...

def load(path: str, clamp_body: Optional[str] = None, endpoint_body: Optional[str] = None,
         wrap: Optional[Literal["opensim", "exact"]] = None,
         force_model: Optional[str] = None) -> Model: ...

def simulate(model: Model, path: str, effects: Sequence[str] = ..., trials: Optional[int] = None,
             seed: int = 1, noise_force: float = 0.002, noise_moment: float = 5e-5,
             joint_range: Optional[float] = None, muscles: Sequence[str] = ...,
             postures: Optional[str] = None, delimiter: str = ",", decimal_comma: bool = False,
             ignore_columns: Sequence[str] = ..., skip_rows: int = 0) -> str: ...
def fit(model: Model, csv: str, max_fit_trials: int = 20000, sample_seed: int = 1,
        rounds: int = 3, folds: int = 5, screen: int = 8, candidates: Sequence[str] = ...,
        loss: str = "huber", loss_scale: float = 2.0, threads: int = 0,
        output: Optional[str] = None, report: Optional[str] = None,
        report_md: Optional[str] = None, progress: Optional[Callable[[str], Any]] = None,
        delimiter: str = ",", decimal_comma: bool = False, ignore_columns: Sequence[str] = ...,
        skip_rows: int = 0) -> Dict[str, Any]: ...
