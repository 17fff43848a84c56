"""MuJoCo software-in-the-loop simulator speaking PX4's simulator MAVLink API."""
