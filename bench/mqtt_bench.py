# SPDX-License-Identifier: MIT
"""drgatewayd's MQTT side, measured (`make bench-mqtt`, docs/performance.md
"MQTT"): drsim at RPI 10 ms, Debian's mosquitto on loopback, paho-mqtt as
the plant.

- Latency: a Modbus client writes int_in[0]; the gateway sends it to the
  robot, drsim echoes it into int_out[0], the gateway receives it and
  publishes it. Measured to the MQTT subscriber seeing int_out[0] in a
  data message, and, as the reference, to a Modbus client polling
  int_out[0] every millisecond. The difference is what MQTT adds; both
  include the robot's round trip (up to two RPIs).
- CPU: the daemon's CPU time over the same wall time with [mqtt]
  (publish_interval_ms = 100, deadband 0: drsim's noise publishes every
  100 ms) and without it.

Not a test: nothing here passes or fails on a number.
"""
import argparse
import os
import struct
import sys
import time
from pathlib import Path

TOP = Path(__file__).resolve().parents[1]


def setup_env(build):
    b = Path(build).resolve()
    os.environ.setdefault("GW_BUILD", str(b))
    os.environ.setdefault("GW_LOGDIR", str(b / "bench" / "mqtt"))
    sys.path.insert(0, str(TOP / "tests" / "gateway"))


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100.0 * (len(xs) - 1))))]


def cpu_s(pid):
    f = Path("/proc/%d/stat" % pid).read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def latency(g, plant, n):
    from gwlib import dint_regs, regs_dint
    mq, mb = [], []
    for k in range(1, n + 1):
        value = k * 7 - 100000
        seen = len(plant.all())
        with g.raw() as m:
            t0 = time.monotonic()
            m.write_regs(300, dint_regs(value, "abcd"))
            while regs_dint(m.read(4, 500, 2), "abcd") != value:
                time.sleep(0.001)
            mb.append(time.monotonic() - t0)
        while True:
            hit = [t for t, (top, p, _) in zip(plant.times[seen:], plant.all()[seen:])
                   if top.endswith("/data") and '"int_out[0]":%d' % value in p]
            if hit:
                mq.append(hit[0] - t0)
                break
            if time.monotonic() - t0 > 5:
                raise RuntimeError("no MQTT message for value %d" % value)
            time.sleep(0.001)
    return mq, mb


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--cpu-seconds", type=float, default=10.0)
    args = ap.parse_args()
    setup_env(args.build)
    from gwlib import running
    from mqttlib import Broker, Plant, mqtt_section

    broker = Broker("bench_mqtt").start()
    try:
        section = mqtt_section(broker, "publish_interval_ms = 0")
        with running("bench_mqtt_lat", extra=section, robot="rpi_ms = 10") as g:
            plant = Plant(broker)
            try:
                wait_for_data(plant)
                mq, mb = latency(g, plant, args.samples)
            finally:
                plant.close()
        cpu = {}
        for label, extra in (("with [mqtt]", mqtt_section(broker)), ("without", "")):
            with running("bench_mqtt_cpu", extra=extra, robot="rpi_ms = 10") as g:
                time.sleep(1.0)
                c0, t0 = cpu_s(g.proc.pid), time.monotonic()
                time.sleep(args.cpu_seconds)
                cpu[label] = (cpu_s(g.proc.pid) - c0) / (time.monotonic() - t0) * 100.0
    finally:
        broker.stop()
    ms = lambda x: "%.1f" % (x * 1000.0)
    print("| path (RPI 10 ms, %d samples) | p50 ms | p99 ms | max ms |" % args.samples)
    print("| --- | --- | --- | --- |")
    for name, xs in (("Modbus write -> robot echo -> MQTT subscriber", mq),
                     ("Modbus write -> robot echo -> Modbus poll (1 ms)", mb)):
        print("| %s | %s | %s | %s |" % (name, ms(pct(xs, 50)), ms(pct(xs, 99)), ms(max(xs))))
    print()
    print("| daemon, 1 robot at RPI 10 ms | CPU %% of one core over %.0f s |" % args.cpu_seconds)
    print("| --- | --- |")
    for label, v in cpu.items():
        print("| %s | %.2f |" % (label, v))


def wait_for_data(plant):
    from gwlib import wait_for
    wait_for(lambda: any(t.endswith("/data") for t, _, _ in plant.all()), 20, "MQTT data")


if __name__ == "__main__":
    main()
