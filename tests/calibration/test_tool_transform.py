"""Tool transform conventions: F' = R^T F, T' = R^T (T - d x F), R = Rx(rx) Ry(ry) Rz(rz)."""

from __future__ import annotations

import numpy as np
import pytest

from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tool_transform import ToolTransform


def _apply(transform: ToolTransform, force, torque):
    return transform.wrench_matrix() @ np.concatenate([force, torque])


def test_pure_translation_moves_torque_by_minus_d_cross_f():
    # d = (0, 0, 10 mm), F = (2, 0, 0) N: d x F = (0, 0.02, 0) N m, so Ty drops by 0.02 N m.
    transform = ToolTransform.from_mm_deg(0, 0, 10, 0, 0, 0)
    result = _apply(transform, [2.0, 0.0, 0.0], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(result, [2.0, 0.0, 0.0, 0.1, 0.18, 0.3], rtol=0, atol=1e-15)


def test_translation_with_general_vectors_matches_cross_product():
    transform = ToolTransform.from_mm_deg(12.0, -7.0, 3.0, 0, 0, 0)
    force, torque = np.array([1.5, -2.0, 4.0]), np.array([0.01, 0.02, -0.03])
    expected_torque = torque - np.cross([0.012, -0.007, 0.003], force)
    np.testing.assert_allclose(_apply(transform, force, torque)[3:], expected_torque, atol=1e-15)


def test_90_degrees_about_z_permutes_axes():
    # New x axis = old y, new y axis = old -x: F' = (Fy, -Fx, Fz), same for torques.
    transform = ToolTransform.from_mm_deg(0, 0, 0, 0, 0, 90)
    result = _apply(transform, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    np.testing.assert_allclose(result, [2.0, -1.0, 3.0, 5.0, -4.0, 6.0], atol=1e-15)


def test_rotation_order_is_x_then_new_y_then_new_z():
    # rx = 90 then ry = 90 about the new y: new x = old y, new y = old z, new z = old x, so
    # F' = (Fy, Fz, Fx). The other order (y first) would give a different permutation.
    transform = ToolTransform.from_mm_deg(0, 0, 0, 90, 90, 0)
    result = _apply(transform, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(result[:3], [2.0, 3.0, 1.0], atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_transform_then_inverse_is_identity(seed):
    rng = np.random.default_rng(seed)
    transform = ToolTransform.from_mm_deg(*rng.uniform(-50, 50, 3), *rng.uniform(-80, 80, 3))
    product = transform.inverse().wrench_matrix() @ transform.wrench_matrix()
    np.testing.assert_allclose(product, np.eye(6), atol=1e-14)


@pytest.mark.parametrize("seed", range(5))
def test_angles_round_trip(seed):
    rng = np.random.default_rng(seed)
    # |ry| < 90 deg keeps the x-y-z angles unique.
    angles_deg = np.concatenate(
        [rng.uniform(-170, 170, 1), rng.uniform(-80, 80, 1), rng.uniform(-170, 170, 1)]
    )
    transform = ToolTransform.from_mm_deg(1, 2, 3, *angles_deg)
    np.testing.assert_allclose(transform.as_mm_deg(), [1, 2, 3, *angles_deg], atol=1e-9)


def test_calibration_tool_transform_replaces_and_applies_to_the_matrix(cal_file_path):
    calibration = AtiCalibration.from_file(cal_file_path("FT8884"))
    first = ToolTransform.from_mm_deg(0, 0, 5, 0, 0, 0)
    second = ToolTransform.from_mm_deg(0, 0, 0, 0, 0, 90)
    transformed = calibration.with_tool_transform(first).with_tool_transform(second)
    np.testing.assert_allclose(
        transformed.matrix_si, second.wrench_matrix() @ calibration.matrix_si, rtol=1e-15
    )
    volts = np.array([0.1, -0.2, 0.3, 0.05, -0.1, 0.2])
    plain = calibration.forces_from_voltages(volts, np.zeros(6))
    rotated = transformed.forces_from_voltages(volts, np.zeros(6))
    np.testing.assert_allclose(
        rotated[[0, 1, 3, 4]], [plain[1], -plain[0], plain[4], -plain[3]], rtol=1e-12
    )
    assert transformed.content_hash == calibration.content_hash
