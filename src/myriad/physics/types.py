"""The engine's enumerations, in one place: host code uses the enums, kernels the constants.

Joint, geom, sensor, object and sensor data types are MuJoCo's values (`mjtJoint`, `mjtGeom`,
`mjtSensor`, `mjtObj`, `mjtDataType`), so a compiled MuJoCo model's arrays are read as they are.
"""

from enum import IntEnum

import warp as wp


class JointType(IntEnum):
    FREE = 0     # 7 qpos (position, quaternion xyzw), 6 dofs (linear, angular)
    BALL = 1     # 4 qpos (quaternion xyzw), 3 dofs
    SLIDE = 2    # 1 qpos, 1 dof, along the axis (m)
    HINGE = 3    # 1 qpos, 1 dof, about the axis (rad)


JOINT_QPOS_SIZE = {JointType.FREE: 7, JointType.BALL: 4, JointType.SLIDE: 1, JointType.HINGE: 1}
JOINT_DOF_SIZE = {JointType.FREE: 6, JointType.BALL: 3, JointType.SLIDE: 1, JointType.HINGE: 1}


class ActuatorKind(IntEnum):
    """How an actuator's force follows from its input u (ctrl, or its activation) and its
    transmission's length l and velocity v (both already times the gear). MuJoCo's motor,
    position and velocity shortcuts have kinds of their own, so that their per-env gains keep
    one meaning; every other fixed or affine gain with an affine bias is `AFFINE`."""
    MOTOR = 0      # force = gain·u
    POSITION = 1   # force = kp·(u − l) − kv·v, implicit in the step
    VELOCITY = 2   # force = kv·(u − v), implicit in the step
    AFFINE = 3     # force = (gain + gain_l·l + gain_v·v)·u + bias − kp·l − kv·v (MuJoCo's
                   # general actuator: gainprm[0:3], biasprm = bias, −kp, −kv)


class WrapType(IntEnum):
    """The elements of a tendon's path (MuJoCo's `mjtWrap`)."""
    JOINT = 1      # fixed tendon: a joint and its coefficient
    PULLEY = 2     # spatial: the branches after it count 1/divisor
    SITE = 3       # spatial: a point the path passes through
    SPHERE = 4     # spatial: a sphere the path between two sites wraps around
    CYLINDER = 5   # spatial: a cylinder, likewise (a helix along its axis)


class DynType(IntEnum):
    """MuJoCo's actuator activation dynamics (`mjtDyn`): the actuator's input is its activation
    `act`, integrated each substep from ctrl, instead of ctrl itself."""
    NONE = 0          # no activation: u = ctrl
    INTEGRATOR = 1    # act' = ctrl
    FILTER = 2        # act' = (ctrl − act) / tau, Euler
    FILTEREXACT = 3   # the same, integrated exactly over the substep


class GeomType(IntEnum):
    PLANE = 0
    HFIELD = 1
    SPHERE = 2
    CAPSULE = 3
    ELLIPSOID = 4
    CYLINDER = 5
    BOX = 6
    MESH = 7     # the convex hull of the mesh's vertices
    TRIMESH = 9  # Myriad's own: a static mesh collided as its triangles, not its hull
                 # (`Model.collide_as_triangles`; MuJoCo's model holds it as a mesh geom)


class SensorType(IntEnum):
    """The MuJoCo sensors Myriad computes (`sensors`); MuJoCo's mjtSensor values."""
    TOUCH = 0           # 1: normal force of the contacts in the site's zone
    ACCELEROMETER = 1   # 3: linear acceleration of the site, site frame (+g up at rest)
    VELOCIMETER = 2     # 3: linear velocity of the site, site frame
    GYRO = 3            # 3: angular velocity, site frame
    FORCE = 4           # 3: force the site's body receives from its parent, site frame
    TORQUE = 5          # 3: torque of the same, about the site, site frame
    JOINTPOS = 9        # 1: hinge or slide position
    JOINTVEL = 10       # 1: hinge or slide velocity
    ACTUATORFRC = 15    # 1: actuator force (before the gear)
    JOINTACTFRC = 16    # 1: summed actuator force at a hinge or slide joint
    FRAMEPOS = 26       # 3: position of an object's frame (world, or the reference frame)
    FRAMEQUAT = 27      # 4: its orientation, quaternion (w, x, y, z)
    FRAMEXAXIS = 28     # 3: its x axis
    FRAMEYAXIS = 29     # 3: its y axis
    FRAMEZAXIS = 30     # 3: its z axis
    FRAMELINVEL = 31    # 3: linear velocity of the frame's origin
    FRAMEANGVEL = 32    # 3: angular velocity
    FRAMELINACC = 33    # 3: linear acceleration of the frame's origin, world (+g up at rest)
    FRAMEANGACC = 34    # 3: angular acceleration, world


class ObjType(IntEnum):
    """Objects sensors are attached to; MuJoCo's mjtObj values."""
    UNKNOWN = 0    # no reference frame
    BODY = 1       # a body's inertial frame (center of mass, principal axes)
    XBODY = 2      # a body's own frame
    JOINT = 3
    GEOM = 5
    SITE = 6
    ACTUATOR = 19


class DataType(IntEnum):
    """How a sensor's cutoff applies; MuJoCo's mjtDataType values."""
    REAL = 0         # clamped to [-cutoff, cutoff]
    POSITIVE = 1     # clamped to at most cutoff
    AXIS = 2         # a unit vector: no cutoff
    QUATERNION = 3   # no cutoff


class RowType(IntEnum):
    """Kind of a constraint row (`constraints`)."""
    INACTIVE = -1  # not in use this substep: skipped
    NORMAL = 0     # unilateral: J v >= target, impulse >= 0 (contacts and limits)
    FRICTION = 1   # first of a contact's two friction rows: solved as a 2D disk
    FRICTION2 = 2  # second friction row (handled with the first)
    SOFT = 3       # implicit spring-damper along J (fixed tendons): force, not constraint
    DOF = 4        # a dof's dry friction (|impulse| <= frictionloss·h) and speed cap
    EQUALITY = 5   # bilateral: J v = target, impulse of either sign (equality constraints)
    SPIN = 6       # a contact's torsional friction: |impulse| <= mu_spin · normal impulse
    ROLL = 7       # first of its two rolling friction rows: a 2D disk of radius mu_roll · normal
    ROLL2 = 8      # second rolling row (handled with the first)


class EqualityType(IntEnum):
    """MuJoCo's equality constraints (`mjtEq`), each a set of hard rows (`constraints`)."""
    CONNECT = 0    # a point of body 1 on a point of body 2 (a ball joint): 3 rows
    WELD = 1       # body 1's frame fixed in body 2's: 3 position rows + 3 orientation rows
    JOINT = 2      # q1 - q1_0 = polynomial(q2 - q2_0): 1 row (a URDF <mimic> joint)
    TENDON = 3     # the same coupling between two fixed tendons' lengths: 1 row


# the same values as kernel constants
FREE = wp.constant(int(JointType.FREE))
BALL = wp.constant(int(JointType.BALL))
SLIDE = wp.constant(int(JointType.SLIDE))
HINGE = wp.constant(int(JointType.HINGE))

MOTOR = wp.constant(int(ActuatorKind.MOTOR))
POSITION = wp.constant(int(ActuatorKind.POSITION))
VELOCITY = wp.constant(int(ActuatorKind.VELOCITY))
AFFINE = wp.constant(int(ActuatorKind.AFFINE))
WRAP_PULLEY = wp.constant(int(WrapType.PULLEY))
WRAP_SITE = wp.constant(int(WrapType.SITE))
WRAP_SPHERE = wp.constant(int(WrapType.SPHERE))
WRAP_CYLINDER = wp.constant(int(WrapType.CYLINDER))
DYN_NONE = wp.constant(int(DynType.NONE))
DYN_INTEGRATOR = wp.constant(int(DynType.INTEGRATOR))
DYN_FILTER = wp.constant(int(DynType.FILTER))
DYN_FILTEREXACT = wp.constant(int(DynType.FILTEREXACT))

PLANE = wp.constant(int(GeomType.PLANE))
HFIELD = wp.constant(int(GeomType.HFIELD))
SPHERE = wp.constant(int(GeomType.SPHERE))
CAPSULE = wp.constant(int(GeomType.CAPSULE))
ELLIPSOID = wp.constant(int(GeomType.ELLIPSOID))
CYLINDER = wp.constant(int(GeomType.CYLINDER))
BOX = wp.constant(int(GeomType.BOX))
MESH = wp.constant(int(GeomType.MESH))
TRIMESH = wp.constant(int(GeomType.TRIMESH))

INACTIVE = wp.constant(int(RowType.INACTIVE))
NORMAL = wp.constant(int(RowType.NORMAL))
FRICTION = wp.constant(int(RowType.FRICTION))
FRICTION2 = wp.constant(int(RowType.FRICTION2))
SOFT = wp.constant(int(RowType.SOFT))
DOF = wp.constant(int(RowType.DOF))
EQUALITY = wp.constant(int(RowType.EQUALITY))
SPIN = wp.constant(int(RowType.SPIN))
ROLL = wp.constant(int(RowType.ROLL))

CONNECT = wp.constant(int(EqualityType.CONNECT))
WELD = wp.constant(int(EqualityType.WELD))
EQ_JOINT = wp.constant(int(EqualityType.JOINT))
EQ_TENDON = wp.constant(int(EqualityType.TENDON))

SENS_TOUCH = wp.constant(int(SensorType.TOUCH))
SENS_ACCELEROMETER = wp.constant(int(SensorType.ACCELEROMETER))
SENS_VELOCIMETER = wp.constant(int(SensorType.VELOCIMETER))
SENS_GYRO = wp.constant(int(SensorType.GYRO))
SENS_FORCE = wp.constant(int(SensorType.FORCE))
SENS_TORQUE = wp.constant(int(SensorType.TORQUE))
SENS_JOINTPOS = wp.constant(int(SensorType.JOINTPOS))
SENS_JOINTVEL = wp.constant(int(SensorType.JOINTVEL))
SENS_ACTUATORFRC = wp.constant(int(SensorType.ACTUATORFRC))
SENS_JOINTACTFRC = wp.constant(int(SensorType.JOINTACTFRC))
SENS_FRAMEPOS = wp.constant(int(SensorType.FRAMEPOS))
SENS_FRAMEQUAT = wp.constant(int(SensorType.FRAMEQUAT))
SENS_FRAMEXAXIS = wp.constant(int(SensorType.FRAMEXAXIS))
SENS_FRAMEYAXIS = wp.constant(int(SensorType.FRAMEYAXIS))
SENS_FRAMEZAXIS = wp.constant(int(SensorType.FRAMEZAXIS))
SENS_FRAMELINVEL = wp.constant(int(SensorType.FRAMELINVEL))
SENS_FRAMEANGVEL = wp.constant(int(SensorType.FRAMEANGVEL))
SENS_FRAMELINACC = wp.constant(int(SensorType.FRAMELINACC))
SENS_FRAMEANGACC = wp.constant(int(SensorType.FRAMEANGACC))

OBJ_UNKNOWN = wp.constant(int(ObjType.UNKNOWN))
OBJ_BODY = wp.constant(int(ObjType.BODY))
OBJ_XBODY = wp.constant(int(ObjType.XBODY))
OBJ_GEOM = wp.constant(int(ObjType.GEOM))
OBJ_SITE = wp.constant(int(ObjType.SITE))

DATA_REAL = wp.constant(int(DataType.REAL))
DATA_POSITIVE = wp.constant(int(DataType.POSITIVE))
