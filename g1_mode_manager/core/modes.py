"""The closed set of control modes and what each one lets through."""

from __future__ import annotations

from enum import IntEnum


class Mode(IntEnum):
    """Values equal the constants of g1_mode_manager_msgs/msg/Mode."""

    UNINITIALIZED = 0
    IDLE = 1
    HIGH_LEVEL = 2
    LOW_LEVEL = 3
    EMERGENCY = 4
    FAULT = 5  # a body check tripped: a protective stop, left only by clear_fault to IDLE (or an e-stop)

    @classmethod
    def parse(cls, text: str) -> Mode:
        """Parse a mode name case-insensitively ('high_level', 'HighLevel', 'high-level').

        Raises ValueError listing the valid names.
        """
        key = text.strip().replace("-", "_").replace(" ", "_").upper()
        aliases = {"HIGHLEVEL": "HIGH_LEVEL", "LOWLEVEL": "LOW_LEVEL", "ESTOP": "EMERGENCY"}
        key = aliases.get(key, key)
        try:
            return cls[key]
        except KeyError:
            names = ", ".join(m.name.lower() for m in cls)
            raise ValueError(f"unknown mode name {text!r}; valid names: {names}") from None

    @classmethod
    def from_value(cls, value: int) -> Mode:
        """Raises ValueError for a number that is no mode."""
        try:
            return cls(value)
        except ValueError:
            valid = ", ".join(f"{m.value} {m.name}" for m in cls)
            raise ValueError(f"unknown mode number {value}; valid: {valid}") from None


def allows_cmd_vel(mode: Mode) -> bool:
    """Velocity commands (LocoClient Move) pass only in HIGH_LEVEL."""
    return mode is Mode.HIGH_LEVEL


def allows_arm_commands(mode: Mode) -> bool:
    """rt/arm_sdk commands pass only in HIGH_LEVEL."""
    return mode is Mode.HIGH_LEVEL


def allows_arm_ramp_out(mode: Mode) -> bool:
    """A hand-back frame (the arm weight going down) passes in every mode but EMERGENCY and FAULT, also while a
    transition runs (leaving HIGH_LEVEL waits for the ramp-out) and while a body check holds motion: after an
    e-stop or a protective stop nothing but damping reaches the robot."""
    return mode not in (Mode.EMERGENCY, Mode.FAULT)


def allows_loco_commands(mode: Mode) -> bool:
    """Posture commands of the built-in controller (StandUp, Start, ...) pass only in HIGH_LEVEL."""
    return mode is Mode.HIGH_LEVEL


def allows_low_level_commands(mode: Mode) -> bool:
    """rt/lowcmd commands pass only in LOW_LEVEL."""
    return mode is Mode.LOW_LEVEL
