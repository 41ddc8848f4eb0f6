"""imu-ident on numpy arrays: the same Rust code as the ``hal-sim`` CLI.

* :func:`adev` -- overlapping Allan deviation with its chi-square confidence interval
  (what ``hal-sim identify`` writes to ``adev.csv``);
* :func:`identify` -- single-series characterisation of a static recording (``hal-sim identify``);
* :func:`replay` -- the firmware's 1 Hz filter step over a log, fixed or adaptive
  (``hal-sim run [--adapt]``);
* :func:`diagnose` -- is the model adequate for the log, and which effect is missing
  (``hal-sim diagnose``);
* :func:`simulate` -- a log drawn from a scenario's truth model (``hal-sim simulate``).

Units are SI throughout (s, m/s, rad, m/s^2, rad/s). A *model* is a model TOML (README, "Model
TOML"): give TOML text, or a path (``str`` naming an existing file, or ``os.PathLike``).
"""

import os
from typing import Any, Dict, Mapping, Optional, Union

import numpy as np

from . import _native

__all__ = ["adev", "identify", "replay", "diagnose", "simulate", "model_toml", "scenario_toml"]

Model = Union[str, "os.PathLike[str]"]


def _model(model: Model):
    """(text or path, is_path) for the native functions."""
    if isinstance(model, os.PathLike):
        return os.fspath(model), True
    if not isinstance(model, str):
        raise TypeError(f"model: expected TOML text or a path, got {type(model).__name__}")
    # TOML text always has a '=' or a newline; a path to an existing file is read.
    if "\n" not in model and "=" not in model:
        if not os.path.isfile(model):
            raise FileNotFoundError(f"model: no such file {model!r} (and not TOML text)")
        return model, True
    return model, False


def _array(name: str, a) -> np.ndarray:
    arr = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    return arr


def _truth(truth: Optional[Mapping[str, Any]]):
    if truth is None:
        return None
    missing = [k for k in ("dv", "delta", "da", "dw") if k not in truth]
    if missing:
        raise ValueError(f"truth: missing keys {missing} (need dv, delta, da, dw)")
    return [_array(f"truth[{k!r}]", truth[k]) for k in ("dv", "delta", "da", "dw")]


def adev(y, rate: float) -> Dict[str, np.ndarray]:
    """Overlapping Allan deviation of ``y`` sampled at ``rate`` Hz, on the octave grid.

    Returns arrays ``tau`` [s], ``m`` (cluster size), ``adev`` (units of y), ``ci_lo``,
    ``ci_hi`` (95 % chi-square interval) and ``edf`` (equivalent degrees of freedom).
    """
    return _native.adev(_array("y", y), float(rate))


def identify(y, rate: float, sensor: str, decimate: int = 1, column: str = "series") -> Dict[str, Any]:
    """Identifies a composite noise model of one axis of a static recording.

    ``y`` in SI units (rad/s for a gyro, m/s^2 for an accelerometer), ``rate`` in Hz,
    ``sensor`` ``"gyro"`` or ``"accel"``. Returns the fields of ``hal-sim identify``'s
    summary.json (``components``: the selected model components with their parameters and
    confidence intervals; ``trials``: the BIC selection; ``residuals``; ``acf``...) and
    ``model_toml``, the text of model.toml (usable as ``model=`` in :func:`replay`).
    """
    return _native.identify(_array("y", y), float(rate), sensor, int(decimate), column)


def replay(t, z, model: Model, adapt: bool = False, truth: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
    """Runs the firmware's 1 Hz filter step (in f64) over the log ``t`` [s], ``z`` [m/s]
    (``NaN`` = missing observation) with ``model``; with ``adapt=True`` it identifies the noise
    model online, starting from ``model``.

    ``truth`` (optional, simulation): a mapping with arrays ``dv``, ``delta``, ``da``, ``dw``.
    Returns ``estimates`` (the columns of estimates.csv as arrays), ``params`` (params.csv),
    ``acf`` (acf.csv) and ``summary`` (summary.json; with ``adapt``, ``identified_model``).
    """
    text, is_path = _model(model)
    return _native.replay(_array("t", t), _array("z", z), text, is_path, bool(adapt), _truth(truth))


def diagnose(t, z, model: Model, truth: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
    """Compares ``model`` with the log ``t``, ``z`` and names the missing effect, if any.

    Returns the fields of diagnosis.json (``verdict``: ``"adequate"``, ``"missing-effect"`` (a
    component to add) or ``"wrong-kind"`` (a component whose kind to replace, named in
    ``replaces``), ``sensor``, ``effect``, ``params``, ``explanation``, ``evidence``,
    ``limits``...) and ``suggested_model_toml``, the model with the named change.
    """
    text, is_path = _model(model)
    return _native.diagnose(_array("t", t), _array("z", z), text, is_path, _truth(truth))


def simulate(scenario: str = "paper", hours: Optional[float] = None, seed: int = 1) -> Dict[str, Any]:
    """Draws ``hours`` of a log from a scenario's truth model (a built-in name such as
    ``"paper"``, or a scenario file), as ``hal-sim simulate`` does with the same seed.

    Returns arrays ``t``, ``z`` and ``truth`` (a dict of ``dv``, ``delta``, ``da``, ``dw``).
    """
    return _native.simulate(os.fspath(scenario), None if hours is None else float(hours), int(seed))


def model_toml(model: Model) -> str:
    """Checks a model (TOML text or path) and returns it in canonical model-TOML form."""
    text, is_path = _model(model)
    return _native.model_toml(text, is_path)


def scenario_toml(name: str = "paper") -> str:
    """The model of a scenario (built-in name or file) as model-TOML text."""
    return _native.scenario_toml(os.fspath(name))
