"""A learned policy in a chaos scenario: the steps that put one at work in the aimed row, the noise's lifecycle
verbs, whether one is at work when the e-stop goes out (the coverage's "policy" column), and what the judge
requires of it on the robot's record.

A policy is at work from its shadow on (the node's ``~/policy/status`` shows a phase other than unloaded or
loaded). Its shadow sends nothing: no frame of the policy's stiffness reaches the robot before an operator asked
for an engage; after that its frames are judged as any user's (scenario.py: on the user_ctrl path only under user
control and never after LOW_LEVEL was left, nothing stiff after the e-stop's Damp, nothing under FAULT or a hold).
"""

from __future__ import annotations

import random
from typing import Any

from g1_mode_manager_msgs.srv import LoadPolicy
from std_srvs.srv import Trigger

from support.holosoma import policy_frame
from support.sim_record import Event

#: Phases of ~/policy/status in which a policy is at work.
AT_WORK = frozenset({"shadow", "engaging", "blending", "running", "holding", "disengaging"})
#: The policies a scenario loads: the two walkers and the two dances (a tracking policy's engage blends the robot to its
#: ready pose under stiff gains, then its clip plays whatever the noise does: its frames are judged as the walkers').
POLICIES = ("loco_ppo", "loco_fastsac", "dance_ppo", "dance_fastsac")
#: The noise's lifecycle verbs, with their weights: a load and a shadow are needed before anything else applies.
NOISE_VERBS = ("load", "load", "shadow", "shadow", "engage", "engage", "disengage", "hold", "unload")
#: The shadow runs this long before the setup engages, s: its targets must be fresh to be compared with the robot.
SHADOW_S = (0.3, 0.8)


#: The setup's verbs that are asked again while refused (a shadow without fresh targets yet, a transition of the
#: noise still under way); the others' refusals stand (nothing to disengage, a policy the noise left at work).
RETRIED = ("shadow", "engage")


def setup_steps(row: str, rng: random.Random) -> list[tuple[float, str, Any]]:
    """After the setup's mode request: whatever the noise left at work stopped, a fresh load, its shadow, and for a
    LOW_LEVEL row the engage (LOW_LEVEL is entered by the engage itself, by the node's path)."""
    steps: list[tuple[float, str, Any]] = [(0.0, "policy", "disengage"), (0.0, "policy", f"load:{rng.choice(POLICIES)}"),
                                           (0.0, "policy", "shadow"), (0.0, "pause", round(rng.uniform(*SHADOW_S), 3))]
    if row in ("LOW_LEVEL", "->LOW_LEVEL"):
        steps.append((0.0, "policy", "engage"))
    return steps


def noise_verb(rng: random.Random) -> str:
    verb = rng.choice(NOISE_VERBS)
    return f"load:{rng.choice(POLICIES)}" if verb == "load" else verb


def call(stack: Any, arg: str, timeout_s: float) -> Any:
    """One lifecycle verb ("load:<policy>", "shadow", "engage", ...); its reply (raises TimeoutError unanswered)."""
    verb, _, name = arg.partition(":")
    if verb == "load":
        return stack.ros.call(LoadPolicy, stack.name("policy/load"), LoadPolicy.Request(policy=name), timeout_s, 5.0)
    return stack.ros.call(Trigger, stack.name(f"policy/{verb}"), Trigger.Request(), timeout_s, 5.0)


def at_work(statuses: list[tuple[float, str, str]], since: float) -> bool:
    """Whether the newest ``(t, phase, last_fault)`` received after ``since`` (the last restart) shows a policy at
    work."""
    newest = [phase for t, phase, _ in statuses if t > since][-1:]
    return bool(newest) and newest[0] in AT_WORK


def judge(events: list[Event], engages: list[float]) -> list[str]:
    """The shadow sends nothing: no frame of the policy's stiffness on the robot before the first engage was
    asked for (``engages``: when each was sent, test clock)."""
    first = min(engages, default=float("inf"))
    early = [e for e in events if policy_frame(e) and e["t"] < first]
    if early:
        return [f"a frame of the policy's stiffness on rt/{early[0]['topic']} at {early[0]['t']:.3f}, before any engage "
                f"was asked for ({first:.3f})"]
    return []


def features(events: list[Event], statuses: list[tuple[float, str, str]]) -> list[str]:
    """What the scenario's policy did: its frames reached the robot, it faulted inside the loop."""
    return [*(["policy frames on the robot"] if any(policy_frame(e) for e in events) else []),
            *(["policy shadowed"] if any(phase == "shadow" for _, phase, _ in statuses) else []),
            *(["policy fault inside the loop"] if any(fault for _, _, fault in statuses) else [])]
