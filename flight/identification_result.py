"""The result of identifying a model file's parameters from one flight log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.flight.discretisation import discretise
from ornitail.flight.fit_report import fit_warnings
from ornitail.flight.linear_simulation import simulate_outputs
from ornitail.flight.model_data import model_data
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.residual_statistics import ResidualTests
from ornitail.flight.state_space import Mode, NumericStateSpace


@dataclass(frozen=True)
class ParameterEstimate:
    """Value, Cramer-Rao standard error and colored-residual corrected standard error (units of
    the parameter). A fixed parameter has both sigmas 0.
    """

    value: float
    sigma: float
    sigma_colored: float
    fixed: bool = False


@dataclass(frozen=True)
class ModeEstimate:
    """A mode of the identified A with standard errors by the delta method: Cramer-Rao (from
    ``covariance``) and colored-residual corrected (from ``covariance_colored``).
    """

    mode: Mode
    sigma_real: float
    sigma_imag: float
    sigma_damping_ratio: float
    sigma_natural_frequency_rad_s: float
    sigma_real_colored: float
    sigma_imag_colored: float
    sigma_damping_ratio_colored: float
    sigma_natural_frequency_rad_s_colored: float


@dataclass
class IdentificationResult:
    """Estimates and diagnostics of one identification (see docs/model-files.md, "Results").

    ``parameters`` holds every parameter of the model file (fixed ones too); ``parameter_names``
    lists the estimated ones, the order of :meth:`parameter_vector` and of ``covariance``
    (Cramer-Rao) and ``covariance_colored``. ``fit`` is 1 - NRMSE per output of the simulated model
    against the data (MATLAB ``compare`` convention, a fraction, 1 = perfect). ``cost`` is the
    negative log-likelihood without constants, N/2 log det R, for output error, and the weighted
    sum of squared equation errors / 2 for equation error.
    """

    model: StateSpaceModelSpec
    method: str
    parameters: dict[str, ParameterEstimate]
    parameter_names: tuple[str, ...]
    covariance: np.ndarray
    covariance_colored: np.ndarray
    constants: dict[str, float]
    initial_state: np.ndarray
    initial_state_sigma: np.ndarray
    fit: dict[str, float]
    eigenvalues: np.ndarray
    modes: list[ModeEstimate]
    residual_tests: ResidualTests
    noise_covariance: np.ndarray
    cost: float
    iterations: int
    converged: bool
    message: str
    time_step_s: float
    sample_count: int
    simulated_outputs: np.ndarray = field(repr=False)

    def parameter_vector(self) -> np.ndarray:
        """Estimated parameter values in the order of ``parameter_names``."""
        return np.array([self.parameters[name].value for name in self.parameter_names])

    def parameter_values(self) -> dict[str, float]:
        """Every parameter's value (estimated and fixed), by name."""
        return {name: estimate.value for name, estimate in self.parameters.items()}

    def model_with_parameters(self) -> NumericStateSpace:
        """Numeric A, B, C, D at the estimates (continuous time, the model's units)."""
        return self.model.state_space(self.parameter_values(), self.constants)

    def simulate(
        self, data: pd.DataFrame, initial_state: str | np.ndarray = "fitted"
    ) -> pd.DataFrame:
        """Simulate the identified model on the inputs of ``data`` (a log with the model's columns).

        ``initial_state``: ``"fitted"`` (the identified x0, right for the log it was fitted
        to), ``"data"`` (the first sample of the state columns), ``"zero"``, or an array.
        Returns a DataFrame with ``time_s`` and one column per output (model units).
        """
        signals = model_data(self.model, data)
        if isinstance(initial_state, str):
            if initial_state == "fitted":
                start = self.initial_state
            elif initial_state == "zero":
                start = np.zeros(len(self.model.states))
            elif initial_state == "data":
                if signals.states is None:
                    raise UserInputError(
                        "initial_state", "the model has states without data columns"
                    )
                start = signals.states[0]
            else:
                raise UserInputError(
                    "initial_state", f"expected fitted, data, zero or an array: {initial_state!r}"
                )
        else:
            start = np.asarray(initial_state, dtype=float)
            if start.shape != (len(self.model.states),):
                raise UserInputError("initial_state", f"needs {len(self.model.states)} values")
        all_parameters = np.array([self.parameters[n].value for n in self.model.parameter_names])
        constants = np.array([signals.constants[n] for n in self.model.constant_names])
        discrete = discretise(self.model, all_parameters, constants, signals.time_step_s)
        outputs, _ = simulate_outputs(discrete, start, signals.inputs)
        frame = pd.DataFrame(outputs, columns=list(self.model.outputs))
        frame.insert(0, "time_s", signals.time_s)
        return frame

    def summary(self) -> dict[str, Any]:
        """The JSON of ``ornitail flight identify`` (plain Python types): each parameter's value
        and sigmas in its ``unit``, the fit per output, the eigenvalues of A (1/s), the input hold
        and the warnings of :func:`~ornitail.flight.fit_report.fit_warnings`.
        """
        return {
            "parameters": {
                name: {
                    "value": estimate.value,
                    "sigma": estimate.sigma,
                    "sigma_colored": estimate.sigma_colored,
                    "unit": self.model.parameter(name).unit,
                }
                for name, estimate in self.parameters.items()
            },
            "fit": dict(self.fit),
            "eigenvalues": [[float(value.real), float(value.imag)] for value in self.eigenvalues],
            "input_hold": self.model.input_hold,
            "warnings": fit_warnings(self.fit, self.residual_tests),
        }
