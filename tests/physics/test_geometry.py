"""Geometry: Eqs. 5-7 and the f_B-cancelling coefficient vector K of Eq. 11."""

import math

import numpy as np
import pytest

from tmopt.physics.geometry import Geometry, null_vector_coefficients, rotation_z


def test_nominal_layout_is_the_equilateral_triangle_of_sec_4_1():
    g = Geometry()
    assert math.degrees(g.phi1) == pytest.approx(60.0)
    assert math.degrees(g.phi2) == pytest.approx(120.0)
    assert math.degrees(g.alpha) == pytest.approx(60.0)
    assert np.linalg.norm(g.r12_s) == pytest.approx(0.4)
    # the arm lines through the TM centres meet 0.4 m from both (third vertex)
    x_a = g.w_sa.T @ [1.0, 0, 0]
    x_b = g.w_sb.T @ [1.0, 0, 0]
    t = np.linalg.solve(np.column_stack([x_a[:2], -x_b[:2]]), (g.r02_s - g.r01_s)[:2])
    assert abs(t[0]) == pytest.approx(0.4) and abs(t[1]) == pytest.approx(0.4)


def test_frame_changes_are_consistent_rotations():
    g = Geometry()
    for w in (g.w_sa, g.w_sb, g.w_ab):
        np.testing.assert_allclose(w @ w.T, np.eye(3), atol=1e-15)
        assert np.linalg.det(w) == pytest.approx(1.0)
    np.testing.assert_allclose(g.w_ab, g.w_sb @ g.w_sa.T, atol=1e-15)  # a -> s -> b
    # components of x_a expressed in frame a must be [1, 0, 0]
    x_a_in_s = np.array([math.cos(g.phi1), math.sin(g.phi1), 0.0])
    np.testing.assert_allclose(g.w_sa @ x_a_in_s, [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(rotation_z(0.0), np.eye(3))


@pytest.mark.parametrize("phi1,phi2", [(60, 120), (50, 130), (30, 100), (70, 95), (10, 250)])
def test_closed_form_k_is_the_null_vector(phi1, phi2):
    g = Geometry(math.radians(phi1), math.radians(phi2))
    np.testing.assert_allclose(g.coefficients(), null_vector_coefficients(g), atol=1e-14)


def test_nominal_k_values():
    np.testing.assert_allclose(
        Geometry().coefficients(), [-math.sqrt(3) / 4, -math.sqrt(3) / 4, 0.75, -0.75]
    )


def test_k_cancels_any_in_plane_spacecraft_acceleration():
    g = Geometry()
    k = g.coefficients()
    rng = np.random.default_rng(0)
    for f_s in rng.normal(size=(20, 3)):
        f_a, f_b = g.w_sa @ f_s, g.w_sb @ f_s
        assert abs(k @ [f_a[0], f_b[0], f_a[1], f_b[1]]) < 1e-15 * np.linalg.norm(f_s) * 10


def test_coaxial_layout_is_rejected():
    with pytest.raises(ValueError, match="alpha"):
        Geometry(0.3, 0.3)
    with pytest.raises(ValueError, match="separation"):
        Geometry(separation=-1.0)
