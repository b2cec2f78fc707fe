"""Example publisher of polarnav's inputs (IMU, aids, init) over iceoryx2
shared memory, for a sensor driver written in Python.

It opens (or creates) the daemon's input service of a stream with the
`iceoryx2` package from PyPI (0.10) and the ctypes mirror in
polarnav_msgs.py, with the options the Rust publishers use: the quality of
service of polarnav_ipc's one table (`polarnav_msgs.QOS`, held to the Rust
side by tests/tests/live.rs), delivery that never blocks (a full reader's
buffer drops the sample for that reader, counted in `lost`), and a
notification on the paired event service `<prefix>/<stream>/event` after
every sample, which wakes the daemon. The daemon takes the first publisher
of a stream and refuses (and counts) the others' samples: `Publisher`
says so when it opens (`second_publisher`). A sample with a NaN or an
infinity, or whose stamp is not after the previous one, is refused here
(`ValueError`, counted in `refused`) and never reaches the daemon.

    pip install iceoryx2==0.10.0
    from publisher import Publisher
    imu = Publisher("polarnav", "imu")
    imu.publish(ImuSample(t_ns=..., seq=..., dt_s=0.005, ...))

Run as a program it replays a feed file (the inputs of a flight as the
tests write them: u32 stream tag, u32 size, the payload's bytes; tag 0
init, 1 imu, 2 + k the aid of AIDS[k]) at SPEED times its stamps' pace:

    python3 examples/python/publisher.py --prefix P --feed FILE [--speed 15]

Like the Rust processes it honours POLARNAV_IOX_PREFIX / POLARNAV_IOX_ROOT.
"""

import argparse
import ctypes
import math
import struct
import sys
import time

import iceoryx2 as iox2

import polarnav_msgs as m
from consumer import node_config


def make_node(role: str, prefix: str):
    return (iox2.NodeBuilder.new()
            .name(iox2.NodeName.new(f"{role}:{prefix}"))
            .config(node_config())
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
            .create(iox2.ServiceType.Ipc))


def floats(value):
    """Every float of a ctypes payload (nested structures and arrays too),
    with the name of the field that holds it."""
    for name, _ in value._fields_:
        v = getattr(value, name)
        if isinstance(v, float):
            yield name, v
        elif isinstance(v, ctypes.Structure):
            yield from floats(v)
        elif isinstance(v, ctypes.Array):
            for x in v:
                if isinstance(x, float):
                    yield name, x
                elif isinstance(x, ctypes.Structure):
                    yield from floats(x)


class Publisher:
    """The publisher of one input stream of the daemon."""

    def __init__(self, prefix: str, stream: str, node=None):
        if stream not in m.INPUTS:
            raise ValueError(f"unknown stream {stream!r} (one of {', '.join(m.INPUTS)})")
        self.stream = stream
        self.payload = m.INPUTS[stream]
        self.node = node if node is not None else make_node(f"driver-{stream}", prefix)
        name = f"{prefix.rstrip('/')}/{stream}"
        buffer, history, overflow = m.qos(stream)
        self.service = (self.node.service_builder(iox2.ServiceName.new(name))
                        .publish_subscribe(self.payload)
                        .subscriber_max_buffer_size(buffer)
                        .history_size(history)
                        .enable_safe_overflow(overflow)
                        .max_publishers(m.MAX_PUBLISHERS)
                        .max_subscribers(m.MAX_SUBSCRIBERS)
                        .max_nodes(m.MAX_NODES)
                        .open_or_create())
        self.second_publisher = self.service.dynamic_config.number_of_publishers > 0
        self.publisher = (self.service.publisher_builder()
                          .backpressure_strategy(iox2.BackpressureStrategy.DiscardData)
                          .create())
        event = (self.node.service_builder(iox2.ServiceName.new(f"{name}/event"))
                 .event()
                 .max_notifiers(m.EVENT_MAX_NOTIFIERS)
                 .max_listeners(m.EVENT_MAX_LISTENERS)
                 .max_nodes(m.MAX_NODES)
                 .open_or_create())
        self.notifier = event.notifier_builder().create()
        self.last_t_ns = None
        self.sent = 0
        self.refused = 0
        self.lost = 0

    def publish(self, sample) -> None:
        """Sends `sample` (an instance of the stream's payload class)."""
        if not isinstance(sample, self.payload):
            raise TypeError(f"a {type(sample).__name__} offered to the {self.stream} publisher")
        for name, x in floats(sample):
            if not math.isfinite(x):
                self.refused += 1
                raise ValueError(f"{self.stream}.{name} is not finite: {x}")
        if self.last_t_ns is not None and sample.t_ns <= self.last_t_ns:
            self.refused += 1
            raise ValueError(f"{self.stream}: stamp {sample.t_ns} ns after {self.last_t_ns} ns")
        # Every reader a send did not reach is a loss (a full buffer, or a
        # reader not connected yet), as polarnav_ipc counts it.
        readers = self.service.dynamic_config.number_of_subscribers
        reached = self.publisher.send_copy(sample)
        readers = max(readers, self.service.dynamic_config.number_of_subscribers)
        self.lost += max(0, readers - reached)
        self.notifier.notify()
        self.last_t_ns = sample.t_ns
        self.sent += 1

    def close(self) -> None:
        self.notifier.delete()
        self.publisher.delete()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--prefix", default="polarnav")
    ap.add_argument("--feed", required=True, help="the inputs to publish (see above)")
    ap.add_argument("--speed", type=float, default=1.0, help="times the stamps' pace")
    args = ap.parse_args()
    iox2.set_log_level_from_env_or(iox2.LogLevel.Warn)
    names = ("init", "imu") + m.AIDS
    node = make_node("driver-python", args.prefix)
    pubs = {}
    t0_wall = t0_ns = None
    with open(args.feed, "rb") as f:
        while head := f.read(8):
            tag, size = struct.unpack("=II", head)
            data = f.read(size)
            if tag >= len(names) or len(data) != size:
                print(f"publisher: bad record (tag {tag}, size {size})", file=sys.stderr)
                return 1
            stream = names[tag]
            if stream not in pubs:
                pubs[stream] = Publisher(args.prefix, stream, node)
                if pubs[stream].second_publisher:
                    print(f"publisher: {stream} already has a publisher: the daemon refuses this one's",
                          file=sys.stderr)
            cls = m.INPUTS[stream]
            if ctypes.sizeof(cls) != size:
                print(f"publisher: {stream} record of {size} bytes, the mirror's is {ctypes.sizeof(cls)}",
                      file=sys.stderr)
                return 1
            sample = cls.from_buffer_copy(data)
            if t0_wall is None:
                t0_wall, t0_ns = time.monotonic(), sample.t_ns
            due = t0_wall + (sample.t_ns - t0_ns) * 1e-9 / args.speed
            if (wait := due - time.monotonic()) > 0:
                time.sleep(wait)
            pubs[stream].publish(sample)
    for stream, p in pubs.items():
        print(f"{stream} sent={p.sent} lost={p.lost} refused={p.refused}")
        p.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
