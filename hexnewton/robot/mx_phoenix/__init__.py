"""MX-Phoenix: Kåre Halvorsen's (Zenta's) hexapod on Robotis Dynamixel MX-64 and MX-106 servos, a robot about 1.6
times the paper's in leg length and 1.7 times its mass.

The dimensions come from the Phoenix code's hardware configuration for it, ``Hex_Cfg.h`` with ``#define MXPhoenix``
(the Phoenix code by KurtE and Zenta, as kept in github.com/mjs513/LSS_Phoenix_BT,
``Zenta_LSS_Phoenix_PhantomX_float_mjs_v0/Hex_Cfg.h``): "Phoenix" below. The servos' masses and torques come from
Robotis's e-manual (emanual.robotis.com/docs/en/dxl/mx/mx-64, .../mx-106): "e-manual". What neither gives is an
estimate, marked as such with what it rests on. The same robot as files, written by us from these numbers:
``mx_phoenix.urdf`` and ``mx_phoenix.xml`` beside this module (``--robot hexnewton/robot/mx_phoenix/mx_phoenix.urdf``);
they load to this description (tests/robot/test_loader.py).
"""

import math
import os

from hexnewton.robot_config import RobotConfig

FOLDER = os.path.dirname(os.path.abspath(__file__))
URDF = os.path.join(FOLDER, "mx_phoenix.urdf")
MJCF = os.path.join(FOLDER, "mx_phoenix.xml")

MX_PHOENIX = RobotConfig(
    name="mx_phoenix",
    # Phoenix: cXXCoxaLength 60, cXXFemurLength 127 ("126,501mm to be exact"), cXXTibiaLength 227 [mm]
    hip_length=0.060,
    femur_length=0.127,
    tibia_length=0.227,
    # estimate: 4.2 kg, the sum below. e-manual: MX-64R/T 126 g, MX-106R/T 153 g; Phoenix: "my MX64/106 based
    # hexapod" (which servo drives which joint is not given: the MX-106 taken at the femur, the most loaded joint)
    total_mass=4.2,
    # estimate: the coxa link carries the femur servo (MX-106, 153 g) and its brackets
    coxa_mass=0.16,
    # estimate: the femur link carries the tibia servo (MX-64, 126 g) and its brackets
    femur_mass=0.16,
    # estimate: the tibia tube and foot
    tibia_mass=0.08,
    # Phoenix: cXXCoxaMin/Max -75/75 [deg]
    hip_limit=(-math.radians(75.0), math.radians(75.0)),
    # Phoenix: cXXFemurMin/Max -120/90 [deg] in the Phoenix code's own sense; estimate: hexnewton's knee (0 = femur
    # level, > 0 lifting) taken as -90..90 deg, the femur's reach from straight down to straight up
    knee_limit=(-math.radians(90.0), math.radians(90.0)),
    # Phoenix: cXXTibiaMin1/Max1 -65/75 [deg]; estimate: the tuck (hexnewton's ankle < 0) taken as its 65 deg side
    ankle_limit=(-math.radians(65.0), math.radians(75.0)),
    # estimate: a box over the hip mounts below (0.21 m between the front and rear mounts, 0.226 m across the middle
    # ones), 6 cm high
    torso_size=(0.24, 0.20, 0.06),
    # Phoenix: cRFOffsetZ -105 / cRFOffsetX -73 (front and rear coxae 105 mm ahead of / behind the centre, 73 mm
    # out), cRMOffsetX -113 (middle coxae 113 mm out) [mm]
    hip_mounts=((0.105, 0.073), (0.0, 0.113), (-0.105, 0.073)),
    # Phoenix: cRFCoxaAngle 55, cRMCoxaAngle 0, cRRCoxaAngle -55 [deg from lateral]
    mount_splay_deg=(55.0, 0.0, -55.0),
    # estimate: the legs' collision radius, about half an MX servo's 40 mm width; a 15 mm rubber foot
    leg_radius=0.015,
    foot_radius=0.015,
    # ours, as the paper robot's: femur 0.15 rad up, tibia vertical (the torso stands 0.23 m high)
    stand_pose=(0.0, 0.15, -0.15),
    # ours: the paper robot's 40 N m/rad and 0.8 N m s/rad scaled by the knee's standing load, mass x femur
    # (4.2 x 0.127 against 2.5 x 0.080: x 2.7, rounded down), so that the robot sags as little
    joint_ke=100.0,
    joint_kd=2.0,
    # e-manual: MX-64 stall torque 6.0 N m at 12 V (the MX-106's 8.4); the weaker servo's for every joint
    effort_limit=6.0,
    # estimate: a coreless rotor of about 1e-7 kg m^2 through the MX gears (200:1, 225:1; e-manual): ~0.005 kg m^2
    armature=0.005,
    # ours: above the standing height (0.23 m), the robot drops onto its feet
    spawn_height=0.25,
)
