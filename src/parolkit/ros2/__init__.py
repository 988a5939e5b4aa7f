"""ROS 2 without a ROS install: the URDF of the PAROL6 and a DDS bridge.

* :mod:`parolkit.ros2.urdf`: the URDF generated from :mod:`parolkit.robot` (standard library
  and numpy only).
* :mod:`parolkit.ros2.msgs`, :mod:`parolkit.ros2.bridge`: ROS 2 message types as cyclonedds
  IDL and the ``parolkit ros2`` node (need the optional ``cyclonedds`` package:
  ``pip install 'parolkit[ros2]'``).
"""
