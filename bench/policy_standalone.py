"""The raw reference of the policy row of `make bench`: holosoma's locomotion model run by a minimal standalone loop
on Unitree's own Python SDK, as the field's deploy scripts do (holosoma-inference, unitree_rl_gym's deploy_real): a
``ChannelSubscriber`` keeping the newest rt/lowstate (a handler per sample, as theirs), the observation built from
it with numpy, one onnxruntime inference (one thread), one rt/user_lowcmd frame per 50 Hz step (the SDK's CRC,
``Write``). Nothing else in the process: no gate, no checks, no status.

Run by bench/policy_rows.py: ``python -m bench.policy_standalone --domain D --seconds 10 --model M --out F``. The
robot is not in user control, so the sim records the frames and ignores them: what is measured is the loop's cost
and timing. Writes JSON: the process's CPU (all its threads, over the loop only), the inference times and the send
times.
"""

from __future__ import annotations

import argparse
import json
import threading
import time

import numpy as np
import onnxruntime as ort

from g1_mode_manager.protocol.dds import init_channels
from harness.rate import run_at_rate

#: holosoma's g1_29dof default_dof_angles and the loco observation's scales (config/config_values).
DEFAULT = np.array([-0.312, 0.0, 0.0, 0.669, -0.363, 0.0] * 2 + [0.0] * 3
                   + [0.2, 0.2, 0.0, 0.6, 0.0, 0.0, 0.0, 0.2, -0.2, 0.0, 0.6, 0.0, 0.0, 0.0])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="policy_standalone", description=__doc__.split("\n\n")[0])
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--seconds", type=float, required=True)
    parser.add_argument("--model", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)

    init_channels(args.domain, "lo")
    from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_
    from unitree_sdk2py.utils.crc import CRC

    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(args.model, options, providers=["CPUExecutionProvider"])
    meta = session.get_modelmeta().custom_metadata_map
    kp, kd = json.loads(meta["kp"]), json.loads(meta["kd"])
    latest: list = [None]
    state = ChannelSubscriber("rt/lowstate", LowState_)
    state.Init(lambda msg: latest.__setitem__(0, msg), 10)
    deadline = time.monotonic() + 5.0
    while latest[0] is None and time.monotonic() < deadline:
        time.sleep(0.01)
    if latest[0] is None:
        raise SystemExit("no rt/lowstate within 5 s")
    pub = ChannelPublisher("rt/user_lowcmd", LowCmd_)
    pub.Init()
    time.sleep(0.5)  # discovery
    msg, crc = unitree_hg_msg_dds__LowCmd_(), CRC()
    obs = np.zeros((1, 100), dtype=np.float32)
    last_action = np.zeros(29)
    phase = np.array([np.pi, np.pi])  # standing: holosoma holds the phase at zero command
    inference: list[float] = []
    sends: list[float] = []
    start_cpu, start = time.process_time(), time.monotonic()

    def step() -> bool:
        nonlocal last_action
        if time.monotonic() - start >= args.seconds:
            return False
        s = latest[0]
        q = np.array([m.q for m in s.motor_state[:29]])
        dq = np.array([m.dq for m in s.motor_state[:29]])
        w, x, y, z = s.imu_state.quaternion
        t0 = time.perf_counter()
        o = obs[0]
        o[0:29] = last_action
        o[29:32] = np.array(s.imu_state.gyroscope) * 0.25
        o[32:35] = 0.0  # command: stand
        o[35:37] = np.cos(phase)
        o[37:66] = q - DEFAULT
        o[66:95] = dq * 0.05
        o[95:98] = -np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
        o[98:100] = np.sin(phase)
        last_action = np.clip(session.run(None, {"actor_obs": obs})[0][0], -100.0, 100.0)
        inference.append(time.perf_counter() - t0)
        target = DEFAULT + 0.25 * last_action
        msg.mode_pr, msg.mode_machine = 0, s.mode_machine
        for i in range(29):
            m = msg.motor_cmd[i]
            m.mode, m.q, m.dq, m.tau, m.kp, m.kd = 1, float(target[i]), 0.0, 0.0, kp[i], kd[i]
        msg.crc = crc.Crc(msg)
        pub.Write(msg)
        sends.append(time.monotonic())
        return True

    run_at_rate(50.0, step, threading.Event())
    cpu_pct = 100.0 * (time.process_time() - start_cpu) / (time.monotonic() - start)
    with open(args.out, "w") as f:
        json.dump({"cpu_pct": cpu_pct, "inference_s": inference, "sends": sends}, f)
    state.Close()
    pub.Close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
