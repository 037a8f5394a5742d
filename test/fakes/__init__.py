"""Test doubles for the robot port and for time."""
