"""Two real Dynamixel humanoids re-created as URDFs for the tests: their structure as their
owners wrote it (link and joint names, origins, rpy, axes, limits, masses), each link's
collision geometry a box the size of its collision mesh's bounding box in the link's frame.

    files = write_real(tmp_path, "darwin")     # tmp_path/darwin.urdf
    files = write_real(tmp_path, "poppy")      # tmp_path/poppy.urdf

The numbers were written down from the owners' files (2026-11-28); the files themselves are
not copied here:

* ``darwin``: Darwin-OP as HumaRobotics / Generation Robots published it (``darwin_description``,
  Simplified BSD), in the copy ``jsweaffordjr/darwinsim`` ``darwin_description/urdf/darwin.urdf``
  (first commit 09e808a), whose owner added four foot sensor pads on revolute joints under each
  sole.  Its ankle links' frames have z along the foot (forward), x up or down; its wrists and
  grippers are revolute joints the real robot does not have; its inertias are wrong by 1000x
  (they are not copied: each box's inertia is the box's).
* ``poppy``: Poppy Humanoid (``poppy-project/poppy-humanoid``
  ``hardware/URDF/robots/Poppy_Humanoid.URDF``, CC-BY-SA): faces -y (its left leg at +x), a
  five-joint spine, five-joint legs, arms held out sideways at zero with elbows whose limits
  let them fold one way only, and a left knee whose limits are its twin's although the two
  knees turn the same way for equal angles (against the geometry).

Masses and boxes are rounded as written (box centre and size [m], mass [kg]).
"""

from __future__ import annotations

from pathlib import Path

ROBOTS = ("darwin", "poppy")

# (name, type, parent, child, xyz [m], rpy [rad], axis, (lower, upper) [rad] or None)
DARWIN_JOINTS = (
    ('base_link_to_body', 'fixed', 'base_link', 'MP_BODY', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), None),
    ('j_camboard', 'fixed', 'MP_HEAD', 'MP_PMDCAMBOARD', (0.0, 0.0, 0.0235), (3.14159, 1.570796, 0.0), (0.0, 0.0, 1.0), None),
    ('j_pan', 'revolute', 'MP_BODY', 'MP_NECK', (0.0, 0.0, 0.0235), (0.0, 0.0, 1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_tilt', 'revolute', 'MP_NECK', 'MP_HEAD', (0.0, 0.0, 0.02715), (-1.570796, 0.0, 1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_back_l', 'fixed', 'MP_BODY', 'MP_BACK_L', (0.0, 0.06035, 0.0), (-1.570796, 0.0, 0.0), (1.0, 0.0, 0.0), None),
    ('j_shoulder_l', 'revolute', 'MP_BACK_L', 'MP_SHOULDER_L', (0.0, 0.0, 0.0), (0.0, 0.0, -1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_high_arm_l', 'revolute', 'MP_SHOULDER_L', 'MP_ARM_HIGH_L', (-0.016, 0.0, 0.02165), (1.570796, 1.570796, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_low_arm_l', 'revolute', 'MP_ARM_HIGH_L', 'MP_ARM_LOW_L', (-0.06, 0.0, -0.016), (-1.570796, 3.14159, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_wrist_l', 'revolute', 'MP_ARM_LOW_L', 'MP_ARM_GRIPPER_FIX_L', (0.048, 0.016, 0.0), (1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_wrist_dummy_l', 'fixed', 'MP_ARM_GRIPPER_FIX_L', 'MP_ARM_GRIPPER_FIX_DUMMY_L', (0.064, -0.01, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), None),
    ('j_gripper_l', 'revolute', 'MP_ARM_GRIPPER_FIX_L', 'MP_ARM_GRIPPER_MOV_L', (0.048, 0.01, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_back_r', 'fixed', 'MP_BODY', 'MP_BACK_R', (0.0, -0.06035, 0.0), (1.570796, 0.0, 0.0), (1.0, 0.0, 0.0), None),
    ('j_shoulder_r', 'revolute', 'MP_BACK_R', 'MP_SHOULDER_R', (0.0, 0.0, 0.0), (0.0, 0.0, -1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_high_arm_r', 'revolute', 'MP_SHOULDER_R', 'MP_ARM_HIGH_R', (0.016, 0.0, 0.02165), (-1.570796, 1.570796, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_low_arm_r', 'revolute', 'MP_ARM_HIGH_R', 'MP_ARM_LOW_R', (-0.06, 0.0, 0.016), (-1.570796, 3.14159, 0.0), (0.0, 0.0, 1.0), (-1.635, 2.617994)),
    ('j_wrist_r', 'revolute', 'MP_ARM_LOW_R', 'MP_ARM_GRIPPER_FIX_R', (0.048, -0.016, 0.0), (1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_wrist_dummy_r', 'fixed', 'MP_ARM_GRIPPER_FIX_R', 'MP_ARM_GRIPPER_FIX_DUMMY_R', (0.064, -0.01, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), None),
    ('j_gripper_r', 'revolute', 'MP_ARM_GRIPPER_FIX_R', 'MP_ARM_GRIPPER_MOV_R', (0.048, 0.01, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_pelvis_l', 'revolute', 'MP_BODY', 'MP_PELVIS_L', (-0.005, 0.037, -0.09355), (0.0, 3.14159, -1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_thigh1_l', 'revolute', 'MP_PELVIS_L', 'MP_THIGH1_L', (0.0, 0.0, 0.028652), (1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_thigh2_l', 'revolute', 'MP_THIGH1_L', 'MP_THIGH2_L', (0.0, 0.0, 0.0), (1.570796, 0.0, -1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_tibia_l', 'revolute', 'MP_THIGH2_L', 'MP_TIBIA_L', (-0.093, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_ankle1_l', 'revolute', 'MP_TIBIA_L', 'MP_ANKLE1_L', (-0.093, 0.0, 0.0), (3.14159, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_ankle2_l', 'revolute', 'MP_ANKLE1_L', 'MP_ANKLE2_L', (0.0, 0.0, 0.0), (-1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_pelvis_r', 'revolute', 'MP_BODY', 'MP_PELVIS_R', (-0.005, -0.037, -0.09355), (0.0, 3.14159, 1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_thigh1_r', 'revolute', 'MP_PELVIS_R', 'MP_THIGH1_R', (0.0, 0.0, 0.028652), (-1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_thigh2_r', 'revolute', 'MP_THIGH1_R', 'MP_THIGH2_R', (0.0, 0.0, 0.0), (1.570796, 0.0, -1.570796), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_tibia_r', 'revolute', 'MP_THIGH2_R', 'MP_TIBIA_R', (0.093, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_ankle1_r', 'revolute', 'MP_TIBIA_R', 'MP_ANKLE1_R', (0.093, 0.0, 0.0), (3.14159, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('j_ankle2_r', 'revolute', 'MP_ANKLE1_R', 'MP_ANKLE2_R', (0.0, 0.0, 0.0), (-1.570796, 0.0, 0.0), (0.0, 0.0, 1.0), (-2.617994, 2.617994)),
    ('left_foot_sensor_m0_j', 'revolute', 'MP_ANKLE2_L', 'left_foot_sensor_m0', (-0.034, -0.01, 0.037), (1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('left_foot_sensor_m1_j', 'revolute', 'MP_ANKLE2_L', 'left_foot_sensor_m1', (-0.034, -0.01, -0.037), (1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('left_foot_sensor_m2_j', 'revolute', 'MP_ANKLE2_L', 'left_foot_sensor_m2', (-0.034, 0.005, 0.0), (1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('left_foot_sensor_m3_j', 'revolute', 'MP_ANKLE2_L', 'left_foot_sensor_m3', (-0.034, -0.025, 0.0), (1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('right_foot_sensor_m0_j', 'revolute', 'MP_ANKLE2_R', 'right_foot_sensor_m0', (0.034, -0.01, 0.037), (-1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('right_foot_sensor_m1_j', 'revolute', 'MP_ANKLE2_R', 'right_foot_sensor_m1', (0.034, -0.01, -0.037), (-1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('right_foot_sensor_m2_j', 'revolute', 'MP_ANKLE2_R', 'right_foot_sensor_m2', (0.034, 0.005, 0.0), (-1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
    ('right_foot_sensor_m3_j', 'revolute', 'MP_ANKLE2_R', 'right_foot_sensor_m3', (0.034, -0.025, 0.0), (-1.5708, 0.0, 1.5708), (0.0, 1.0, 0.0), (-0.001, 0.001)),
)
DARWIN_LINKS = (  # (name, mass [kg], box centre [m] or None, box size [m] or None)
    ('base_link', 0.0, None, None),
    ('MP_BODY', 0.9756, (-0.0207, 0.0, -0.0352), (0.1152, 0.126, 0.1255)),
    ('MP_NECK', 0.02436, (0.0, 0.0012, 0.0162), (0.045, 0.0245, 0.0325)),
    ('MP_HEAD', 0.15804, (0.0, -0.0265, 0.0), (0.1001, 0.0959, 0.088)),
    ('MP_BACK_L', 0.01, (0.0, 0.0, 0.0), (0.001, 0.001, 0.001)),
    ('MP_SHOULDER_L', 0.02591, (-0.0056, 0.0, 0.0166), (0.0383, 0.045, 0.0332)),
    ('MP_ARM_HIGH_L', 0.16838, (-0.031, 0.0017, -0.0026), (0.0937, 0.0419, 0.0508)),
    ('MP_ARM_LOW_L', 0.05929, (0.016, 0.016, 0.0), (0.032, 0.032, 0.035)),
    ('MP_ARM_GRIPPER_FIX_L', 0.01, (0.016, 0.0, 0.0), (0.064, 0.032, 0.032)),
    ('MP_ARM_GRIPPER_FIX_DUMMY_L', 0.01, (0.0, 0.0, 0.0), (0.032, 0.005, 0.032)),
    ('MP_ARM_GRIPPER_MOV_L', 0.01, (0.016, -0.0025, 0.0), (0.032, 0.01, 0.032)),
    ('MP_BACK_R', 0.01, (0.0, 0.0, 0.0), (0.001, 0.001, 0.001)),
    ('MP_SHOULDER_R', 0.02591, (0.0056, 0.0, 0.0166), (0.0383, 0.0451, 0.0332)),
    ('MP_ARM_HIGH_R', 0.16838, (-0.031, -0.0016, -0.0026), (0.0936, 0.0419, 0.0508)),
    ('MP_ARM_LOW_R', 0.05929, (0.016, -0.016, 0.0), (0.032, 0.032, 0.035)),
    ('MP_ARM_GRIPPER_FIX_R', 0.01, (0.016, 0.0, 0.0), (0.064, 0.032, 0.032)),
    ('MP_ARM_GRIPPER_FIX_DUMMY_R', 0.01, (0.0, 0.0, 0.0), (0.032, 0.005, 0.032)),
    ('MP_ARM_GRIPPER_MOV_R', 0.01, (0.016, -0.0025, 0.0), (0.032, 0.01, 0.032)),
    ('MP_PELVIS_L', 0.167, (0.0, 0.0028, 0.017), (0.027, 0.0505, 0.034)),
    ('MP_THIGH1_L', 0.11904, (-0.0017, 0.0133, 0.0206), (0.0419, 0.051, 0.0833)),
    ('MP_THIGH2_L', 0.11904, (-0.0469, -0.0045, 0.0), (0.1194, 0.045, 0.055)),
    ('MP_TIBIA_L', 0.07031, (-0.0439, 0.0015, 0.0), (0.1218, 0.067, 0.064)),
    ('MP_ANKLE1_L', 0.16711, (0.0134, -0.0206, -0.0017), (0.0508, 0.0833, 0.0419)),
    ('MP_ANKLE2_L', 0.07945, (-0.0155, -0.0105, 0.0003), (0.036, 0.066, 0.1047)),
    ('MP_PELVIS_R', 0.197, (0.0, -0.0028, 0.017), (0.027, 0.0505, 0.034)),
    ('MP_THIGH1_R', 0.11904, (-0.0017, -0.0134, 0.0206), (0.0419, 0.0508, 0.0833)),
    ('MP_THIGH2_R', 0.11904, (0.0469, -0.0045, 0.0), (0.1194, 0.045, 0.055)),
    ('MP_TIBIA_R', 0.07031, (0.0439, 0.0015, 0.0), (0.1218, 0.067, 0.064)),
    ('MP_ANKLE1_R', 0.16711, (-0.0133, -0.0206, -0.0017), (0.051, 0.0833, 0.0419)),
    ('MP_ANKLE2_R', 0.07945, (0.0155, -0.0105, 0.0003), (0.036, 0.066, 0.1047)),
    ('MP_PMDCAMBOARD', 0.0, None, None),
    ('left_foot_sensor_m0', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('left_foot_sensor_m1', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('left_foot_sensor_m2', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('left_foot_sensor_m3', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('right_foot_sensor_m0', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('right_foot_sensor_m1', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('right_foot_sensor_m2', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
    ('right_foot_sensor_m3', 0.01, (0.0, 0.0, 0.0), (0.025, 0.025, 0.002)),
)


# Poppy Humanoid: the same columns
POPPY_JOINTS = (
    ('r_hip_x', 'revolute', 'pelvis', 'r_hip', (-0.022542, 0.0, 0.0), (1.570796, 0.0, 0.0), (0.0, 0.0, -1.0), (-0.497419, 0.523599)),
    ('r_hip_z', 'revolute', 'r_hip', 'r_hip_motor', (-0.043999, 0.0, 0.005), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0), (-1.570796, 0.436332)),
    ('r_hip_y', 'revolute', 'r_hip_motor', 'r_thigh', (0.0, -0.024, 0.0), (0.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (-1.48353, 1.832596)),
    ('r_knee_y', 'revolute', 'r_thigh', 'r_shin', (0.0, -0.182, 0.0), (0.0, 1.570796, 0.0), (0.0, 0.0, -1.0), (-2.338741, 0.061087)),
    ('r_ankle_y', 'revolute', 'r_shin', 'r_foot', (0.0, -0.18, 0.0), (0.0, -1.5708, 0.0), (-1.0, 0.0, 0.0), (-0.785398, 0.785398)),
    ('l_hip_x', 'revolute', 'pelvis', 'l_hip', (0.022542, 0.0, 0.0), (1.570796, 0.0, 0.0), (0.0, 0.0, -1.0), (-0.523599, 0.497419)),
    ('l_hip_z', 'revolute', 'l_hip', 'l_hip_motor', (0.043999, 0.0, 0.005), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0), (-0.436332, 1.570796)),
    ('l_hip_y', 'revolute', 'l_hip_motor', 'l_thigh', (0.0, -0.024, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (-1.815142, 1.466077)),
    ('l_knee_y', 'revolute', 'l_thigh', 'l_shin', (0.0, -0.182, 0.0), (0.0, 1.570796, 0.0), (0.0, 0.0, -1.0), (-0.061087, 2.338741)),
    ('l_ankle_y', 'revolute', 'l_shin', 'l_foot', (0.0, -0.18, 0.0), (0.0, -1.5708, 0.0), (1.0, 0.0, 0.0), (-0.785398, 0.785398)),
    ('abs_y', 'revolute', 'pelvis', 'abs_motors', (0.0, -0.017, 0.061), (1.570796, 0.0, 0.0), (-1.0, 0.0, 0.0), (-0.872665, 0.20944)),
    ('abs_x', 'revolute', 'abs_motors', 'abdomen', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-0.785398, 0.785398)),
    ('abs_z', 'revolute', 'abdomen', 'spine', (0.0, 0.051637, 0.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.570796, 1.570796)),
    ('bust_y', 'revolute', 'spine', 'bust_motors', (0.0, 0.07985, 0.0028), (0.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (-1.169371, 0.471239)),
    ('bust_x', 'revolute', 'bust_motors', 'chest', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-0.698132, 0.698132)),
    ('head_z', 'revolute', 'chest', 'neck', (0.0, 0.084, 0.005), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.570796, 1.570796)),
    ('head_y', 'revolute', 'neck', 'head', (0.0, 0.02, 0.0), (-0.349066, 0.0, 0.0), (-1.0, 0.0, 0.0), (-0.785398, 0.10472)),
    ('l_shoulder_y', 'revolute', 'chest', 'l_shoulder', (0.0771, 0.05, 0.004), (-1.570796, 0.0, 0.0), (1.0, 0.0, 0.0), (-2.094395, 2.70526)),
    ('l_shoulder_x', 'revolute', 'l_shoulder', 'l_shoulder_motor', (0.0284, 0.0, 0.0), (3.141593, 0.0, 1.570796), (0.0, 0.0, 1.0), (-1.832596, 1.919862)),
    ('l_arm_z', 'revolute', 'l_shoulder_motor', 'l_upper_arm', (0.0, 0.03625, 0.0185), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.832596, 1.832596)),
    ('l_elbow_y', 'revolute', 'l_upper_arm', 'l_forearm', (0.0, 0.11175, -0.01), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (-2.583087, 0.017453)),
    ('r_shoulder_y', 'revolute', 'chest', 'r_shoulder', (-0.0771, 0.05, 0.004), (-1.570796, 0.0, 0.0), (-1.0, 0.0, 0.0), (-2.70526, 2.094395)),
    ('r_shoulder_x', 'revolute', 'r_shoulder', 'r_shoulder_motor', (-0.0284, 0.0, 0.0), (3.141593, 0.0, -1.570796), (0.0, 0.0, -1.0), (-1.919862, 1.832596)),
    ('r_arm_z', 'revolute', 'r_shoulder_motor', 'r_upper_arm', (0.0, 0.03625, 0.0185), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.832596, 1.832596)),
    ('r_elbow_y', 'revolute', 'r_upper_arm', 'r_forearm', (0.0, 0.11175, -0.01), (0.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (-0.017453, 2.583087)),
)
POPPY_LINKS = (
    ('pelvis', 0.1852, (0.0, -0.0051, 0.0157), (0.0809, 0.0558, 0.1226)),
    ('r_hip', 0.08438, (-0.0262, 0.0142, -0.0051), (0.0753, 0.0515, 0.0571)),
    ('r_hip_motor', 0.08317, (-0.0005, -0.022, -0.0171), (0.0499, 0.0441, 0.0621)),
    ('r_thigh', 0.11639, (0.0095, -0.0895, 0.002), (0.0728, 0.2089, 0.0642)),
    ('r_shin', 0.11558, (-0.0029, -0.0895, 0.024), (0.0612, 0.205, 0.0494)),
    ('r_foot', 0.04679, (0.0196, -0.0126, 0.0291), (0.0534, 0.0448, 0.1483)),
    ('l_hip', 0.08438, (0.0262, 0.0142, -0.005), (0.0754, 0.0515, 0.0571)),
    ('l_hip_motor', 0.08317, (0.0006, -0.0221, -0.017), (0.0504, 0.0441, 0.0621)),
    ('l_thigh', 0.11485, (-0.0095, -0.0895, 0.002), (0.0728, 0.209, 0.0642)),
    ('l_shin', 0.11558, (-0.003, -0.0895, -0.0239), (0.0617, 0.205, 0.0496)),
    ('l_foot', 0.04683, (-0.0197, -0.0126, 0.0292), (0.0534, 0.0448, 0.1466)),
    ('abs_motors', 0.16767, (0.0006, 0.017, -0.0221), (0.05, 0.0621, 0.095)),
    ('abdomen', 0.03841, (-0.0001, 0.0216, -0.0213), (0.065, 0.0728, 0.0985)),
    ('spine', 0.09268, (0.0, 0.046, -0.0114), (0.0474, 0.0938, 0.0544)),
    ('bust_motors', 0.15888, (0.0017, 0.0133, -0.0204), (0.0493, 0.0506, 0.0859)),
    ('chest', 0.26293, (0.0, 0.0362, -0.0178), (0.1689, 0.0963, 0.0853)),
    ('neck', 0.00588, (0.0, 0.0157, 0.0), (0.048, 0.0315, 0.023)),
    ('head', 0.18856, (-0.0003, 0.0402, -0.0154), (0.1335, 0.1144, 0.1299)),
    ('l_shoulder', 0.00844, (0.0206, 0.0019, -0.0085), (0.0411, 0.0356, 0.047)),
    ('l_shoulder_motor', 0.08281, (0.0, 0.0154, 0.0068), (0.0386, 0.0548, 0.0496)),
    ('l_upper_arm', 0.16814, (0.0017, 0.0615, -0.0111), (0.0486, 0.1245, 0.0592)),
    ('l_forearm', 0.04865, (-0.0001, 0.0986, -0.0007), (0.0472, 0.2296, 0.0602)),
    ('r_shoulder', 0.00848, (-0.0205, 0.0019, -0.0085), (0.0411, 0.0355, 0.047)),
    ('r_shoulder_motor', 0.08281, (0.0, 0.0154, 0.0069), (0.0386, 0.0548, 0.0493)),
    ('r_upper_arm', 0.16814, (-0.0017, 0.0615, -0.0112), (0.0486, 0.1245, 0.0594)),
    ('r_forearm', 0.04865, (-0.0001, 0.0986, -0.0007), (0.0481, 0.2296, 0.0601)),
)


def _box_inertia(mass: float, size: tuple[float, float, float]) -> tuple[float, float, float]:
    x, y, z = size
    return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)


def _fmt(values) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def real_urdf(robot: str) -> str:
    """The URDF text of ``robot`` (one of :data:`ROBOTS`)."""
    joints, links = {"darwin": (DARWIN_JOINTS, DARWIN_LINKS), "poppy": (POPPY_JOINTS, POPPY_LINKS)}[robot]
    out = ['<?xml version="1.0"?>', f'<robot name="{robot}">']
    for name, mass, centre, size in links:
        out.append(f'  <link name="{name}">')
        if mass > 0 and size is not None:  # a link with no mass in the file gets no inertial (as there)
            ixx, iyy, izz = _box_inertia(mass, size)
            out.append(f'    <inertial><origin xyz="{_fmt(centre)}"/><mass value="{mass:.9g}"/>'
                       f'<inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" izz="{izz:.6g}"/></inertial>')
        if size is not None:
            out.append(f'    <collision><origin xyz="{_fmt(centre)}"/><geometry><box size="{_fmt(size)}"/></geometry>'
                       '</collision>')
        out.append("  </link>")
    for name, kind, parent, child, xyz, rpy, axis, limits in joints:
        out.append(f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                   f'<origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>')
        if kind != "fixed":
            out.append(f'    <axis xyz="{_fmt(axis)}"/><limit lower="{limits[0]:.9g}" upper="{limits[1]:.9g}" '
                       'effort="2.5" velocity="5.6"/>')
        out.append("  </joint>")
    out.append("</robot>\n")
    return "\n".join(out)


def write_real(folder: Path, robot: str) -> Path:
    """``folder/<robot>.urdf`` written; its path."""
    path = Path(folder) / f"{robot}.urdf"
    path.write_text(real_urdf(robot))
    return path
