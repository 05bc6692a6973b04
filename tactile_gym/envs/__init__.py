"""Gymnasium environments. Everything here may import pybullet (through ``tactile_gym.sim``)."""
