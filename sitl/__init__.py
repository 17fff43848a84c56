"""MuJoCo software-in-the-loop simulator speaking PX4's simulator MAVLink API."""

import os

# The downward camera renders headless (sitl.camera): MuJoCo reads this when it is first imported.
os.environ.setdefault("MUJOCO_GL", "egl")
