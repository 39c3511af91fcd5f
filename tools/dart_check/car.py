"""DeepRacer's simulated car built in DART from simapp's own URDF and meshes (the referee's body).

Runs under ``.venv-dart`` only (``tools/dart_check/setup.sh``); never imports drx.

The car is the one simapp's launch builds (``../shared/deepracer-car/``):

- version 6 (simapp 6.0.5, 01f5f015): ``urdf/deepracer/deepracer_single_cam_lidar.urdf``, since
  ``racecar.launch.py`` hard-codes ``include_lidar_sensor`` to ``'true'``; 7.54 kg.
- version 5 (simapp 5.3.3, 608b024b): ``urdf/deepracer/deepracer_single_cam.urdf``; 6.56 kg.

What is changed from the file, and why (each a difference between DART's URDF loader and what
Gazebo makes of the same file, not a choice of ours):

- the ``<xacro:unless>`` / ``<xacro:if>`` wrappers are dropped: they only choose visuals by body shell
  (``macros.xacro``), and DART's loader reads plain URDF;
- ``base_link`` has no ``<inertial>``: DART gives it 1 kg, Gazebo's URDF-to-SDF conversion lumps it
  away (fixed joint to ``chassis``), so it gets a negligible mass here and the car weighs what the
  URDF's inertials add up to;
- a zero mass (v5's ``car_body_link_v3``) is invalid in DART: it gets the same negligible mass;
- only the wheels keep collision shapes. The body's collision mesh (``car_body_link_v3.STL``) sits
  2 cm above the ground, and the 6 cm ``<box>`` collisions of ``car_body_link_v3`` and the camera
  links (two of them nested, malformed, inside ``<inertial>``) sit at the links' origins; the body's
  would reach 1 cm below the wheels' contact plane and carry the car (DART put 72 of its 74 N on
  them), which the logs rule out: simapp 5's car holds 3.9-4.1 m/s^2 of lateral acceleration at
  speed (docs/DYNAMICS.md, the grip envelope), which needs the wheels (friction 0.5) to carry
  nearly all of the weight. ``racecar.gazebo`` also gives the lumped ``chassis`` friction 0.

The wheels' collision meshes are used as they are (radius 0.0360 m rear, 0.0362 m front, where
simapp divides the speed by 0.035 m), with friction mu 0.5 (``racecar.gazebo``: ``mu1 = mu2 = 0.5``).
"""

from __future__ import annotations

import re
from pathlib import Path

import dartpy as dart
import numpy as np

PACKAGE = "deepracer_simulation_environment"  # package:// name the URDF's meshes use
URDF_BY_VERSION = {
    "6": "urdf/deepracer/deepracer_single_cam_lidar.urdf",
    "5": "urdf/deepracer/deepracer_single_cam.urdf",
}
WHEELS = ("left_rear_wheel", "right_rear_wheel", "left_front_wheel", "right_front_wheel")
HINGES = ("left_steering_hinge", "right_steering_hinge")
NEGLIGIBLE_MASS = 1e-6  # [kg] for links Gazebo lumps away or the URDF leaves massless
TYRE_FRICTION = 0.5  # racecar.gazebo mu1 = mu2
GROUND_FRICTION = 1.0  # DART takes the lower of the two: the tyres' 0.5 decides
WHEEL_CENTRE_HEIGHT = 0.023249 + 0.01575  # [m] base_link -> chassis -> rear wheel joint
WHEEL_RADIUS = 0.036  # [m] the rear wheels' collision mesh


def plain_urdf(text: str) -> str:
    """The URDF with the xacro wrappers that choose visuals removed (their content kept)."""
    return re.sub(r"</?xacro:(unless|if)[^>]*>", "", text)


def build_car(car_dir: Path, version: str) -> dart.dynamics.Skeleton:
    """simapp's car of ``version`` ("5" or "6") as a DART skeleton on a free root joint."""
    urdf = car_dir / f"v{version}" / URDF_BY_VERSION[version]
    loader = dart.utils.DartLoader()
    # the meshes are simapp 6's (v5's are the same files: ../shared/deepracer-car/README.md)
    loader.addPackageDirectory(PACKAGE, str(car_dir / "v6"))
    skel = loader.parseSkeletonString(plain_urdf(urdf.read_text()), dart.common.Uri(f"file://{urdf}"))
    if skel is None:
        raise RuntimeError(f"DART could not load {urdf}")
    for body in skel.getBodyNodes():
        name = body.getName()
        if name == "base_link" or body.getMass() <= 0.0:
            body.setMass(NEGLIGIBLE_MASS)
            body.setMomentOfInertia(1e-9, 1e-9, 1e-9, 0.0, 0.0, 0.0)
        for shape in list(body.getShapeNodes()):
            if not shape.hasCollisionAspect():
                continue
            if name in WHEELS:
                shape.getDynamicsAspect().setFrictionCoeff(TYRE_FRICTION)
            else:
                shape.removeCollisionAspect()
                if shape.hasDynamicsAspect():
                    shape.removeDynamicsAspect()
    return skel


def total_mass(skel: dart.dynamics.Skeleton) -> float:
    """The car's mass [kg] as DART has it."""
    return float(sum(b.getMass() for b in skel.getBodyNodes()))


def ground() -> dart.dynamics.Skeleton:
    """A flat, fixed floor: a 400 m square box whose top is z = 0."""
    skel = dart.dynamics.Skeleton("ground")
    _, body = skel.createWeldJointAndBodyNodePair()
    shape = dart.dynamics.BoxShape(np.array([400.0, 400.0, 1.0]))
    node = body.createShapeNode(shape)
    node.createCollisionAspect()
    node.createDynamicsAspect().setFrictionCoeff(GROUND_FRICTION)
    tf = dart.math.Isometry3()
    tf.set_translation(np.array([0.0, 0.0, -0.5]))
    body.getParentJoint().setTransformFromParentBodyNode(tf)
    return skel
