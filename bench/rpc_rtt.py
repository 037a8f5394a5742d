"""RPC round trip of the Unitree SDK2 on one Cyclone DDS stack against another (docs/robot_compat.md).

SDK-only (runs in .venv or .venv-cyclone010): ``python -m bench.rpc_rtt server DOMAIN`` serves a "bench"
service; ``python -m bench.rpc_rtt client DOMAIN [N]`` times N GetServerApiVersion calls (after 50 to
warm up) and prints the median and p99 in ms. On cyclonedds 11 ``protocol.dds.init_channels`` applies the
robot type fix and configures lo for unicast + multicast (as the sim bridge), so both stacks discover each
other.
"""

import statistics
import sys
import time


def _init(domain: int) -> str:
    from importlib.metadata import version

    stack = f"cyclonedds {version('cyclonedds')}"
    if stack.startswith("cyclonedds 0.10"):  # the robot's stack: the SDK's own set-up, as on a robot
        from unitree_sdk2py.core import channel

        channel.ChannelFactoryInitialize(domain, "lo")
    else:  # 11: the robot type fix, and lo served like the sim bridge, so that 0.10 finds it too
        from g1_mode_manager.protocol.dds import init_channels

        init_channels(domain, "lo", serve_multicast=True)
    return stack


def main(argv: list[str]) -> int:
    role, domain = argv[0], int(argv[1])
    stack = _init(domain)
    if role == "server":
        from unitree_sdk2py.rpc.server import Server

        server = Server("bench")
        server._SetApiVersion("1.0.0.0")
        server.Start()
        print(f"server on {stack}", flush=True)
        while True:
            time.sleep(1.0)
    from unitree_sdk2py.rpc.client import Client

    client = Client("bench", False)
    client._SetApiVerson("1.0.0.0")
    client.SetTimeout(1.0)
    deadline = time.monotonic() + 20.0
    while client.GetServerApiVersion()[0] != 0:
        if time.monotonic() > deadline:
            print("server not found", flush=True)
            return 1
        time.sleep(0.1)
    n = int(argv[2]) if len(argv) > 2 else 500
    times = []
    for k in range(50 + n):
        t0 = time.perf_counter()
        code, _ = client.GetServerApiVersion()
        if code == 0 and k >= 50:
            times.append((time.perf_counter() - t0) * 1e3)
    times.sort()
    print(f"client on {stack}: n={len(times)} median {statistics.median(times):.2f} ms "
          f"p99 {times[int(0.99 * (len(times) - 1))]:.2f} ms", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
