"""The compiled models agree with the constants and with each other."""

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from mbc.errors import ModelLoadError
from mbc.fuzz import random_joint_positions, random_quaternion_wxyz
from mbc.robot import JointMap, digit_mjspec, load_pinocchio, pinocchio_configuration, pinocchio_velocity
from robots.digit import constants as digit
from robots.digit.urdf import URDF_PATH, urdf_text


@pytest.fixture(scope="module")
def pin_model():
    return load_pinocchio()


@pytest.fixture(scope="module")
def mj_model():
    return digit_mjspec().compile()


def test_committed_urdf_is_generated_from_constants():
    assert URDF_PATH.read_text() == urdf_text(), "run `python -m robots.digit.urdf` after changing constants"


def test_total_mass(pin_model, mj_model):
    assert digit.TOTAL_MASS_KG == pytest.approx(47.9254, abs=1e-4)
    assert pin.computeTotalMass(pin_model) == pytest.approx(digit.TOTAL_MASS_KG, abs=1e-9)
    assert mujoco.mj_getTotalmass(mj_model) == pytest.approx(digit.TOTAL_MASS_KG, abs=1e-9)


def test_stand_com_height_and_flat_soles(pin_model):
    data = pin_model.createData()
    jmap = JointMap.for_pinocchio(pin_model)
    q = pinocchio_configuration([0, 0, digit.PELVIS_HEIGHT_STAND_M], [1, 0, 0, 0], digit.Q_STAND, jmap)
    com = pin.centerOfMass(pin_model, data, q)
    assert com[2] == pytest.approx(digit.COM_HEIGHT_STAND_M, abs=1e-4)
    pin.framesForwardKinematics(pin_model, data, q)
    for sole in digit.SOLE_FRAMES:
        placement = data.oMf[pin_model.getFrameId(sole)]
        assert placement.translation[2] == pytest.approx(0.0, abs=1e-4)
        np.testing.assert_allclose(placement.rotation, np.eye(3), atol=1e-12)


def test_joint_maps_both_ways(pin_model, mj_model):
    pin_map, mj_map = JointMap.for_pinocchio(pin_model), JointMap.for_mujoco(mj_model)
    mj_q, pin_q = np.arange(mj_model.nq)[mj_map.q], np.arange(pin_model.nq)[pin_map.q]
    for k, name in enumerate(digit.JOINT_NAMES):  # column -> name
        mj_joint = next(j for j in range(mj_model.njnt) if mj_model.jnt_qposadr[j] == mj_q[k])
        assert mj_model.joint(mj_joint).name == name
        pin_joint = next(j for j in range(1, pin_model.njoints) if pin_model.idx_qs[j] == pin_q[k])
        assert pin_model.names[pin_joint] == name
    for j in range(1, mj_model.njnt):  # name -> column
        assert mj_q[digit.JOINT_NAMES.index(mj_model.joint(j).name)] == mj_model.jnt_qposadr[j]
    # every joint column is used exactly once
    assert sorted(mj_q) == list(range(7, 19)) and sorted(np.arange(pin_model.nv)[pin_map.v]) == list(range(6, 18))


def test_limits_match_constants(mj_model):
    jmap = JointMap.for_mujoco(mj_model)
    joint_ids = [mj_model.joint(n).id for n in digit.JOINT_NAMES]
    np.testing.assert_allclose(mj_model.jnt_range[joint_ids], np.c_[digit.Q_MIN_RAD, digit.Q_MAX_RAD], atol=1e-8)
    np.testing.assert_allclose(mj_model.dof_armature[jmap.v], digit.ARMATURE_KGM2)
    np.testing.assert_allclose(mj_model.actuator_forcerange, np.c_[-digit.TORQUE_LIMIT_NM, digit.TORQUE_LIMIT_NM])
    # mirror symmetry: right ranges of x/z joints are the negated, swapped left ones
    left, right = slice(0, 6), slice(6, 12)
    for k, link in enumerate(digit.LEFT_LEG):
        lo, hi = digit.Q_MIN_RAD[left][k], digit.Q_MAX_RAD[left][k]
        expected = (lo, hi) if link.axis[1] else (-hi, -lo)
        assert (digit.Q_MIN_RAD[right][k], digit.Q_MAX_RAD[right][k]) == pytest.approx(expected)


def test_pinocchio_and_mujoco_agree_at_random_configurations(pin_model, mj_model, rng):
    pin_data, mj_data = pin_model.createData(), mujoco.MjData(mj_model)
    pin_map, mj_map = JointMap.for_pinocchio(pin_model), JointMap.for_mujoco(mj_model)
    mj_soles = [mj_model.body(s).id for s in digit.SOLE_FRAMES]
    for _ in range(20):
        base, quat, joints = rng.normal(size=3), random_quaternion_wxyz(rng), random_joint_positions(rng)
        mj_data.qpos[:3], mj_data.qpos[3:7], mj_data.qpos[mj_map.q] = base, quat, joints
        mj_data.qvel[:] = 0.0
        mujoco.mj_forward(mj_model, mj_data)
        q = pinocchio_configuration(base, quat, joints, pin_map)
        com = pin.centerOfMass(pin_model, pin_data, q)
        pin.framesForwardKinematics(pin_model, pin_data, q)
        np.testing.assert_allclose(com, mj_data.subtree_com[0], atol=1e-6)
        for sole, body in zip(digit.SOLE_FRAMES, mj_soles):
            np.testing.assert_allclose(pin_data.oMf[pin_model.getFrameId(sole)].translation, mj_data.xpos[body], atol=1e-6)
            np.testing.assert_allclose(pin_data.oMf[pin_model.getFrameId(sole)].rotation,
                                       mj_data.xmat[body].reshape(3, 3), atol=1e-9)
        # generalized gravity on the joints: the same dynamics in both libraries
        gravity = pin.computeGeneralizedGravity(pin_model, pin_data, q)
        np.testing.assert_allclose(gravity[pin_map.v], mj_data.qfrc_bias[mj_map.v], atol=1e-6)


def test_velocity_conversion_gives_same_momentum(pin_model, mj_model, rng):
    """Pinocchio's centroidal momentum equals MuJoCo's subtree momentum for the same motion."""
    pin_data, mj_data = pin_model.createData(), mujoco.MjData(mj_model)
    pin_map, mj_map = JointMap.for_pinocchio(pin_model), JointMap.for_mujoco(mj_model)
    base, quat, joints = rng.normal(size=3), random_quaternion_wxyz(rng), random_joint_positions(rng)
    v_world, w_world, qd = rng.normal(size=3), rng.normal(size=3), rng.normal(size=12)
    mj_data.qpos[:3], mj_data.qpos[3:7], mj_data.qpos[mj_map.q] = base, quat, joints
    mujoco.mj_kinematics(mj_model, mj_data)
    rotation = mj_data.xmat[mj_model.body("pelvis").id].reshape(3, 3)
    mj_data.qvel[:3], mj_data.qvel[3:6], mj_data.qvel[mj_map.v] = v_world, rotation.T @ w_world, qd
    mujoco.mj_forward(mj_model, mj_data)
    mujoco.mj_subtreeVel(mj_model, mj_data)
    q = pinocchio_configuration(base, quat, joints, pin_map)
    v = pinocchio_velocity(quat, v_world, w_world, qd, pin_map)
    h = pin.computeCentroidalMomentum(pin_model, pin_data, q, v)
    np.testing.assert_allclose(h.linear, digit.TOTAL_MASS_KG * mj_data.subtree_linvel[0], atol=1e-9)
    np.testing.assert_allclose(h.angular, mj_data.subtree_angmom[0], atol=1e-9)


def test_bad_model_file_raises_clear_error(tmp_path):
    with pytest.raises(ModelLoadError, match="not found"):
        load_pinocchio(tmp_path / "missing.urdf")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(ModelLoadError, match="could not parse"):
        load_pinocchio(broken)
    with pytest.raises(ModelLoadError, match="could not parse"):
        digit_mjspec(broken)
