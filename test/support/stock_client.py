"""A stock-style Unitree SDK2 client, as a robot's user would write it: nothing of this project imported.

Run ``python stock_client.py DOMAIN STEP...`` with any interpreter that has ``unitree_sdk2py`` (the main
venv on cyclonedds 11, or ``.venv-cyclone010`` on the robot's Cyclone 0.10.2). It initialises the SDK the
SDK's own way, ``ChannelFactoryInitialize(DOMAIN, "lo")``, so discovery is whatever that gives on this
Cyclone (11: multicast on lo; 0.10: unicast), and uses only the SDK's classes: ``LocoClient``,
``MotionSwitcherClient``, ``ChannelPublisher``/``ChannelSubscriber`` and ``CRC``. With ``--type-fix`` (needed
on cyclonedds 11 to match a robot) it describes uint8/int8 as Cyclone 0.10 does before the first topic.

Steps, in the order given: ``stand`` (Damp, StandUp until static), ``getup`` (Damp, until rt/lowstate shows the
robot lying; StandUp, watched for ``--quiet-s=S`` (2 s unless given), then Lie2StandUp until static), ``squat``
(StandUp2Squat until static), ``start`` (Start only), ``walk`` (Start, Move 0.5 m/s for 2.5 s, StopMove), ``arm``
(rt/arm_sdk: weight 0 -> 1 -> 0 with the left shoulder raised), ``arm7`` (rt/arm_sdk the way Unitree's C++
``g1_arm7_sdk_dds_example.cpp`` writes it: no CRC, the weight 1 at once, the left shoulder pitch ramped at
0.5 rad/s), ``arm7_py`` (rt/arm_sdk as Unitree's Python ``g1_arm7_sdk_dds_example.py`` writes it, its poses and
phases whole: about 21 s), ``release`` (ReleaseMode), ``damp`` (SelectMode("ai") then Damp). Each prints one JSON line
``{"step", "t", ...codes}``; the caller judges what the robot did from the robot's side. Exit 0 once every
step ran, 1 if the server never answered.
"""

from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

ARM_SDK_TOPIC, LOWSTATE_TOPIC = "rt/arm_sdk", "rt/lowstate"
ARM_JOINTS = range(12, 29)  # waist + both arms, as in Unitree's arm_sdk example
WEIGHT_INDEX = 29  # motor_cmd[29].q carries the arm_sdk weight
LEFT_SHOULDER_PITCH = 15
#: Lying: the IMU tilted past the fall check's angle (Unitree's terminations.hpp: 1 rad) and the body at rest on the
#: floor (a falling body turns at several rad/s).
LYING_TILT_RAD, AT_REST_RAD_S = 1.0, 0.5


def emit(step: str, **fields: Any) -> None:
    print(json.dumps({"step": step, "t": time.monotonic(), **fields}), flush=True)


def wait_server(client: Any, budget_s: float = 15.0) -> int:
    """A fresh client is not matched at once (3102): probe the api version as the SDK's examples retry."""
    deadline = time.monotonic() + budget_s
    while True:
        code, _ = client.GetServerApiVersion()
        if code == 0 or time.monotonic() > deadline:
            return code
        time.sleep(0.1)


def wait_static(loco: Any, budget_s: float = 15.0) -> int:
    """Poll GetFsmMode (7002) until the controller is static (a stand-up finished); returns the last mode."""
    deadline = time.monotonic() + budget_s
    mode = -1
    while time.monotonic() < deadline:
        code, data = loco._Call(7002, "{}")
        mode = json.loads(data)["data"] if code == 0 and data else -1
        if mode == 0:
            break
        time.sleep(0.1)
    return mode


def stand(loco: Any) -> None:
    loco.Damp()
    time.sleep(0.3)
    code = loco.SetFsmId(4)
    emit("stand", code=code, static=wait_static(loco))


def fsm_id(loco: Any) -> int:
    """GetFsmId (7001), which this SDK's LocoClient lacks: through its generic call."""
    code, data = loco._Call(7001, "{}")
    return json.loads(data)["data"] if code == 0 and data else -1


def wait_lying(lowstate: Any, budget_s: float = 15.0) -> bool:
    """Read rt/lowstate until its IMU shows the robot lying on the floor (a fall takes about a second: a fixed
    wait would have to be much longer to be sure of it); False if it never did within ``budget_s``."""
    deadline = time.monotonic() + budget_s
    while time.monotonic() < deadline:
        state = lowstate.Read(1.0)
        if state is not None:
            _, x, y, _ = state.imu_state.quaternion
            tilt = math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))
            if tilt > LYING_TILT_RAD and max(abs(g) for g in state.imu_state.gyroscope) < AT_REST_RAD_S:
                return True
        time.sleep(0.02)
    return False


def getup(loco: Any, lowstate: Any, quiet_s: float) -> None:
    """The G1 loco example's Lie2StandUp option, as its comment asks (the robot on its back): Damp, wait
    until the robot lies, then Lie2StandUp; a StandUp (SetFsmId 4: this SDK has no StandUp) tried first, and
    the robot watched for ``quiet_s``, shows what the lying robot does with it."""
    loco.Damp()
    lying = wait_lying(lowstate)
    stand_up_code = loco.SetFsmId(4)
    time.sleep(quiet_s)
    after_stand_up = fsm_id(loco)
    loco.Lie2StandUp()
    time.sleep(0.3)
    emit("getup", lying=lying, stand_up_code=stand_up_code, after_stand_up=after_stand_up,
         static=wait_static(loco), fsm=fsm_id(loco))


def squat(loco: Any) -> None:
    """The example's StandUp2Squat option, from standing."""
    loco.StandUp2Squat()
    time.sleep(0.3)
    emit("squat", static=wait_static(loco), fsm=fsm_id(loco))


def start(loco: Any) -> None:
    loco.Start()
    emit("start")


def walk(loco: Any) -> None:
    loco.Start()
    loco.Move(0.5, 0.0, 0.0, True)
    time.sleep(2.5)
    loco.StopMove()
    time.sleep(0.5)
    emit("walk")


def arm(publisher: Any, lowstate: Any) -> None:
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
    from unitree_sdk2py.utils.crc import CRC

    state = lowstate.Read(2.0)
    if state is None:
        emit("arm", error="no rt/lowstate")
        return
    q0 = [m.q for m in state.motor_state[:29]]
    crc = CRC()
    frames = 0
    for k in range(0, 101):  # 1 s in, 1 s out at 50 Hz
        weight = min(k, 100 - k) / 50.0
        msg = unitree_hg_msg_dds__LowCmd_()
        for i in ARM_JOINTS:
            m = msg.motor_cmd[i]
            m.q = -0.8 if i == LEFT_SHOULDER_PITCH else q0[i]
            m.kp, m.kd = 60.0, 1.5
        msg.motor_cmd[WEIGHT_INDEX].q = weight
        msg.crc = crc.Crc(msg)
        publisher.Write(msg)
        frames += 1
        time.sleep(0.02)
    emit("arm", frames=frames)


def arm7(publisher: Any, lowstate: Any, target: float = -0.9) -> None:
    """As ``g1_arm7_sdk_dds_example.cpp`` does: one LowCmd_ reused for every frame and never given a CRC (its
    crc field stays 0), the weight in motor 29's q set to 1 from the first frame, kp 60, kd 1.5, 50 Hz, each
    joint target moved by at most 0.5 rad/s x 0.02 s a frame; then the weight stepped down. The example's
    arm poses are replaced by the pose it starts from with only the left shoulder pitch raised to ``target``,
    and its phases are shortened."""
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_

    state = lowstate.Read(2.0)
    if state is None:
        emit("arm7", error="no rt/lowstate")
        return
    q0 = [m.q for m in state.motor_state[:29]]
    msg = unitree_hg_msg_dds__LowCmd_()
    control_dt, max_joint_delta = 0.02, 0.5 * 0.02
    desired = {i: q0[i] for i in ARM_JOINTS}

    def send(weight: float) -> None:
        msg.motor_cmd[WEIGHT_INDEX].q = weight
        for i in ARM_JOINTS:
            m = msg.motor_cmd[i]
            m.q, m.dq, m.kp, m.kd, m.tau = desired[i], 0.0, 60.0, 1.5, 0.0
        publisher.Write(msg)
        time.sleep(control_dt)

    frames = 0
    for _ in range(25):  # hold the pose it found, the weight at 1 at once
        send(1.0)
        frames += 1
    while desired[LEFT_SHOULDER_PITCH] != target:  # lift: at most max_joint_delta a frame
        step = target - desired[LEFT_SHOULDER_PITCH]
        desired[LEFT_SHOULDER_PITCH] += max(-max_joint_delta, min(max_joint_delta, step))
        send(1.0)
        frames += 1
    for _ in range(25):
        send(1.0)
        frames += 1
    state = lowstate.Read(1.0)
    lifted = None if state is None else state.motor_state[LEFT_SHOULDER_PITCH].q
    weight = 1.0
    while weight > 0.0:  # stop: the weight stepped down, then 0
        weight = max(0.0, weight - 0.05)
        send(weight)
        frames += 1
    emit("arm7", frames=frames, crc=msg.crc, shoulder_before=q0[LEFT_SHOULDER_PITCH], shoulder_lifted=lifted,
         target=target)


#: The Python arm7 example's arms-out pose, by motor: both shoulders rolled out a quarter turn, elbows bent a
#: quarter turn; every other waist and arm joint it drives goes to 0.
ARM7_PY_POSE = {16: math.pi / 2, 18: math.pi / 2, 23: -math.pi / 2, 25: math.pi / 2}
ARM7_PY_DT_S, ARM7_PY_STAGE_S = 0.02, 3.0


def arm7_py_command(elapsed_s: float, measured: list[float], stage_s: float = ARM7_PY_STAGE_S,
                    ) -> tuple[list[float] | None, float | None]:
    """What unitree_sdk2_python's ``example/g1/high_level/g1_arm7_sdk_dds_example.py`` (37116c5) writes in the frame
    at ``elapsed_s`` (its own clock: the frame count x 20 ms, summed), for ``measured`` = the 17 waist and arm
    positions in motor order (12..28) as its lowstate callback last had them: (targets for motors 12..28, weight);
    None where that frame leaves the value as the last one set it (it reuses one LowCmd_); ``None, None`` once it
    is done. ``stage_s`` is its ``duration_``. Each target blends the goal with the position measured for that
    frame, so a joint that lags is never pulled harder:

    1. to ``stage_s``: the weight 1 from the first frame; targets shrink towards the zero pose (measured x (1 - r)).
    2. to 3 ``stage_s``: towards the arms-out pose (:data:`ARM7_PY_POSE`), r x pose + (1 - r) x measured.
    3. to 6 ``stage_s``: back towards the zero pose, as in 1.
    4. to 7 ``stage_s``: the weight ramped from 1 down, the targets left as they were. Its clock is a sum of 0.02 s
       steps, so the last frame of the ramp carries a weight of about 1e-13, never 0."""
    first = ARM_JOINTS[0]

    def blend(r: float, goal: dict[int, float]) -> list[float]:
        r = min(max(r, 0.0), 1.0)
        return [r * goal.get(i, 0.0) + (1.0 - r) * measured[i - first] for i in ARM_JOINTS]

    if elapsed_s < stage_s:
        return blend(elapsed_s / stage_s, {}), 1.0
    if elapsed_s < 3 * stage_s:
        return blend((elapsed_s - stage_s) / (2 * stage_s), ARM7_PY_POSE), None
    if elapsed_s < 6 * stage_s:
        return blend((elapsed_s - 3 * stage_s) / (3 * stage_s), {}), None
    if elapsed_s < 7 * stage_s:
        return None, 1.0 - min((elapsed_s - 6 * stage_s) / stage_s, 1.0)
    return None, None


def arm7_py(publisher: Any, lowstate: Any) -> None:
    """Unitree's Python arm7 example's frames (:func:`arm7_py_command`) as it sends them: one LowCmd_ reused for every
    frame, CRC computed, ``mode_machine`` and the motors' ``mode`` left 0, kp 60, kd 1.5, dq and tau 0 on motors
    12..28, a frame every 20 ms on a fixed timer from the first rt/lowstate on. Once done it writes its last frame on
    until its main thread, which looks once a second, ends the process: here until the next whole second."""
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
    from unitree_sdk2py.utils.crc import CRC

    state = lowstate.Read(2.0)
    if state is None:
        emit("arm7_py", error="no rt/lowstate")
        return
    msg, crc = unitree_hg_msg_dds__LowCmd_(), CRC()
    for i in ARM_JOINTS:
        m = msg.motor_cmd[i]
        m.dq, m.tau, m.kp, m.kd = 0.0, 0.0, 60.0, 1.5
    elapsed, frames, done = 0.0, 0, False
    started = next_at = time.monotonic()
    while not done or time.monotonic() - started < math.ceil(7 * ARM7_PY_STAGE_S):
        elapsed += ARM7_PY_DT_S
        targets, weight = arm7_py_command(elapsed, [state.motor_state[i].q for i in ARM_JOINTS])
        done = done or (targets, weight) == (None, None)
        if targets is not None:
            for i, q in zip(ARM_JOINTS, targets, strict=True):
                msg.motor_cmd[i].q = q
        if weight is not None:
            msg.motor_cmd[WEIGHT_INDEX].q = weight
        msg.crc = crc.Crc(msg)
        publisher.Write(msg)
        frames += 1
        next_at += ARM7_PY_DT_S
        time.sleep(max(0.0, next_at - time.monotonic()))
        newest = lowstate.Read(0.1)  # the reader keeps only the last sample
        state = state if newest is None else newest
    emit("arm7_py", frames=frames, last_weight=msg.motor_cmd[WEIGHT_INDEX].q, crc=msg.crc)


def main(argv: list[str]) -> int:
    type_fix = "--type-fix" in argv
    quiet_s = next((float(a.split("=", 1)[1]) for a in argv if a.startswith("--quiet-s=")), 2.0)
    args = [a for a in argv if not a.startswith("--")]
    domain, steps = int(args[0]), args[1:]
    if type_fix:
        from cyclonedds.idl._typesupport.DDS import XTypes

        XTypes.TK_UINT8 = XTypes.TK_BYTE
        XTypes.TK_INT8 = XTypes.TK_CHAR8
    from unitree_sdk2py.comm.motion_switcher.motion_switcher_client import MotionSwitcherClient
    from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.g1.loco.g1_loco_client import LocoClient
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_

    ChannelFactoryInitialize(domain, "lo")
    loco = LocoClient()
    loco.SetTimeout(3.0)
    loco.Init()
    switcher = MotionSwitcherClient()
    switcher.SetTimeout(5.0)
    switcher.Init()
    publisher = ChannelPublisher(ARM_SDK_TOPIC, LowCmd_)
    publisher.Init()
    lowstate = ChannelSubscriber(LOWSTATE_TOPIC, LowState_)
    lowstate.Init()
    codes = (wait_server(loco), wait_server(switcher))
    emit("connected", codes=list(codes))
    if codes != (0, 0):
        return 1
    for step in steps:
        if step == "stand":
            stand(loco)
        elif step == "walk":
            walk(loco)
        elif step == "getup":
            getup(loco, lowstate, quiet_s)
        elif step == "start":
            start(loco)
        elif step == "squat":
            squat(loco)
        elif step == "arm":
            arm(publisher, lowstate)
        elif step == "arm7":
            arm7(publisher, lowstate)
        elif step == "arm7_py":
            arm7_py(publisher, lowstate)
        elif step == "release":
            code, _ = switcher.ReleaseMode()
            emit("release", code=code, check=switcher.CheckMode()[1])
        elif step == "damp":
            select, _ = switcher.SelectMode("ai")
            emit("damp", select_code=select, damp_code=loco.SetFsmId(1))
        else:
            emit(step, error="unknown step")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
