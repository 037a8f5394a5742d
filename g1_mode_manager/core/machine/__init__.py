"""The mode state machine: the transition table executed against a ModePort, with e-stop priority.

``ModeMachine`` (facade.py) is the API; each guarantee lives in one file beside it.
"""

from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.machine.facade import ModeMachine
from g1_mode_manager.core.records import MachineStatus, Outcome, Result, TransitionRecord

__all__ = ["EstopTiming", "MachineStatus", "ModeMachine", "Outcome", "Result", "TransitionRecord"]
