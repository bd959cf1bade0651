"""A simulated device in a process of its own, on a bus that crosses processes.

python-can's ``virtual`` bus lives inside one process. A gyro on a real bench is another
machine: its frames reach the station through the kernel's network stack, arrive with
the kernel's receive time stamps, and keep coming when the station stalls. Running the
simulated node in a child process on python-can's ``udp_multicast`` bus gives the same
conditions, and the adapter under test opens the bus exactly as it would open any
python-can interface.

The parent keeps a :class:`RemoteSimCore`: the same operator controls and ledger as a
local :class:`~devices.sim.faults.SimCore` (pause, resume, counts, recent history),
answered by the child over a pipe, and a copy of the child's clock. Both processes read
the system-wide monotonic clock, so the copy counts the same simulated seconds.
"""

from __future__ import annotations

import ipaddress
import secrets
import socket
import subprocess
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Protocol

import numpy as np

from devices.errors import DeviceConfigurationError, DeviceDisconnectedError
from devices.sim.clock import WarpClock
from devices.sim.faults import Ledger, SimCore
from devices.transports.can import CanTransport

#: Organisation-local IPv4 multicast block (RFC 2365) the simulated buses draw from.
_SIM_GROUPS = ipaddress.ip_network("239.255.0.0/16")


@dataclass(frozen=True)
class MulticastChannel:
    """A python-can ``udp_multicast`` bus: a multicast group and a UDP port.

    Two buses on one host are kept apart by their ports as well as their groups.
    ``loopback`` (the default) keeps the bus on 127.0.0.1; False opens it on every
    interface (python-can's own socket), with a warning.
    """

    group: str
    port: int
    loopback: bool = True

    @classmethod
    def fresh(cls, *, loopback: bool = True) -> MulticastChannel:
        """An unused channel: a random group of 239.255.0.0/16 and a free UDP port."""
        group = _SIM_GROUPS[secrets.randbelow(_SIM_GROUPS.num_addresses - 2) + 1]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("", 0))
            port = probe.getsockname()[1]
        return cls(str(group), port, loopback)

    def transport(self) -> CanTransport:
        """A transport on this bus (each end of the link opens its own)."""
        return CanTransport("udp_multicast", self.group, loopback_only=self.loopback,
                            port=self.port)


class LocalSimulator(Protocol):
    """A simulated device started in the child (a CAN broadcaster, a CANopen node)."""

    core: SimCore

    def stop(self) -> None:
        """Stop it and release its transport."""


#: Operator controls and read-outs the parent may ask of the child's core.
_CALLS = frozenset({"pause", "resume", "history", "clear_faults", "stop_after"})
_READS = frozenset({"ledger", "history_start", "sample_rate_hz", "held"})


def _serve(factory: Callable[[], LocalSimulator], conn: Connection) -> None:
    """Child process: start the device, then answer the parent until it says stop or
    goes away (the device stops with it either way)."""
    try:
        simulator = factory()
    except Exception as exc:  # reported to the parent, which raises it as its own error
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", None))
    try:
        while True:
            try:
                name, args = conn.recv()
            except (EOFError, OSError):
                break  # the parent is gone
            if name == "stop":
                break
            core = simulator.core
            try:
                if name in _CALLS:
                    value = getattr(core, name)(*args)
                elif name in _READS:
                    value = getattr(core, name)
                else:
                    raise ValueError(f"no such request {name!r}")
            except Exception as exc:
                conn.send(("error", f"{type(exc).__name__}: {exc}"))
            else:
                conn.send(("ok", value))
    finally:
        simulator.stop()
        conn.close()


class RemoteSimCore:
    """The parent's handle on a simulated device's core running in a child process.

    It offers what the station and the tests use of a :class:`SimCore`: the clock,
    :meth:`pause`, :meth:`resume`, :attr:`ledger`, :meth:`history`,
    :attr:`history_start`, :attr:`sample_rate_hz`. Each read asks the child; it is safe
    from several threads.
    """

    def __init__(self, conn: Connection, clock: WarpClock, describe: str) -> None:
        self.clock = clock
        self._conn = conn
        self._lock = threading.Lock()
        self._describe = describe

    def _ask(self, name: str, *args: Any) -> Any:
        with self._lock:
            try:
                self._conn.send((name, args))
                status, value = self._conn.recv()
            except (EOFError, OSError) as exc:
                raise DeviceDisconnectedError(
                    f"{self._describe}: the simulator process is gone ({exc})") from exc
        if status != "ok":
            raise DeviceConfigurationError(f"{self._describe}: {value}")
        return value

    def close(self) -> None:
        """Tell the child to stop its device and exit (no answer is awaited)."""
        with self._lock:
            try:
                self._conn.send(("stop", ()))
            except OSError:
                pass
            self._conn.close()

    def clear_faults(self) -> None:
        """Turn the faults off (see :meth:`SimCore.clear_faults`)."""
        self._ask("clear_faults")

    def pause(self) -> None:
        """Hold sampling (see :meth:`SimCore.pause`)."""
        self._ask("pause")

    def stop_after(self, n_samples: int | None) -> int | None:
        """Generate no sample beyond the first ``n_samples`` (see :meth:`SimCore.stop_after`)."""
        end: int | None = self._ask("stop_after", n_samples)
        return end


    def resume(self, run_for_s: float | None = None) -> None:
        """Release the operator's hold, ending ``run_for_s`` after it (see
        :meth:`SimCore.resume`)."""
        self._ask("resume", run_for_s)

    @property
    def held(self) -> bool:
        """Whether sampling is stopped now."""
        return bool(self._ask("held"))

    @property
    def ledger(self) -> Ledger:
        """A snapshot of the child's ledger (samples generated, delivered, lost)."""
        ledger: Ledger = self._ask("ledger")
        return ledger

    @property
    def sample_rate_hz(self) -> float:
        """The device's nominal sample rate now, Hz."""
        return float(self._ask("sample_rate_hz"))

    @property
    def history_start(self) -> int:
        """Index of the oldest sample whose rates the child keeps."""
        return int(self._ask("history_start"))

    def history(self, indices: np.ndarray | int | None = None) -> np.ndarray:
        """Rates (deg/s) of kept samples, as :meth:`SimCore.history`."""
        rates: np.ndarray = self._ask("history", indices)
        return rates


class SimulatorProcess:
    """A simulated device run by ``factory`` in a child Python process.

    The child is a fresh interpreter (``python -m devices.sim.process``), not a fork nor
    a ``multiprocessing`` spawn: it never re-imports the caller's main script, and it
    exits when the parent does (its end of the socket pair closes).

    Parameters
    ----------
    factory : callable
        Picklable (a module-level function or a :func:`functools.partial` of one); run
        in the child, it builds and starts the device and returns it. It must build the
        device's core on ``clock``.
    clock : WarpClock
        The simulated clock, shared with the child (pickled with its origin).
    describe : str
        Names the device in error messages.
    start_timeout_s : float
        Longest wait for the child to start, wall s (it imports numpy and the models).
    """

    def __init__(self, factory: Callable[[], LocalSimulator], clock: WarpClock, *,
                 describe: str = "simulated device", start_timeout_s: float = 60.0) -> None:
        self.factory = factory
        self.describe = describe
        self.start_timeout_s = start_timeout_s
        self._clock = clock
        self._process: subprocess.Popen[bytes] | None = None
        self._core: RemoteSimCore | None = None

    @property
    def core(self) -> RemoteSimCore:
        """The handle on the child's core.

        Raises
        ------
        DeviceDisconnectedError
            The simulator was not started.
        """
        if self._core is None:
            raise DeviceDisconnectedError(f"{self.describe}: the simulator process was not "
                                          f"started")
        return self._core

    @property
    def pid(self) -> int | None:
        """The child's process id (None before start)."""
        return None if self._process is None else self._process.pid

    def start(self) -> SimulatorProcess:
        """Start the child and wait until its device runs; returns self.

        Raises
        ------
        DeviceConfigurationError
            The device could not start (its error message is passed on).
        DeviceDisconnectedError
            The child did not answer within ``start_timeout_s``.
        """
        ours, theirs = socket.socketpair()
        with theirs:
            self._process = subprocess.Popen(
                [sys.executable, "-m", "devices.sim.process", str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        conn = Connection(ours.detach())
        conn.send(self.factory)
        if not conn.poll(self.start_timeout_s):
            self.kill()
            raise DeviceDisconnectedError(f"{self.describe}: the simulator process did not "
                                          f"start within {self.start_timeout_s:g} s")
        try:
            status, value = conn.recv()
        except EOFError:
            status, value = "error", f"the process exited with code {self._process.wait(5)}"
        if status != "ready":
            conn.close()
            self._process.wait(5)
            raise DeviceConfigurationError(f"{self.describe}: {value}")
        self._core = RemoteSimCore(conn, self._clock, self.describe)
        return self

    def stop(self) -> None:
        """Ask the child to stop its device and exit; kill it if it does not."""
        process = self._process
        if process is None:
            return
        if self._core is not None and process.poll() is None:
            self._core.close()
        try:
            process.wait(5)
        except subprocess.TimeoutExpired:
            self.kill()

    def kill(self) -> None:
        """SIGKILL the child: the node loses power mid-run (no goodbye on the bus)."""
        process = self._process
        if process is not None and process.poll() is None:
            process.kill()
            process.wait(5)


def main(argv: list[str]) -> int:
    """Child entry point: ``python -m devices.sim.process FD`` (FD: its socket end)."""
    conn = Connection(int(argv[1]))
    try:
        factory = conn.recv()
    except EOFError:
        return 1
    _serve(factory, conn)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
