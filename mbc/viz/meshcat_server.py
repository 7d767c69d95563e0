"""The meshcat server, bound to loopback and tied to the program that started it.

meshcat 0.3.2 starts its server with `listen(port)`, which binds the web server to every interface,
and the server outlives its parent when that one is interrupted (Ctrl-C, SIGTERM) or killed. This
module runs meshcat's server (`ZMQWebSocketBridge`) with its web server on 127.0.0.1, and ends it
when its parent process ends however it ends: the kernel sends it SIGTERM when the parent dies
(Linux `PR_SET_PDEATHSIG`) and, as a fallback elsewhere, it checks its parent every half second.

    python -m mbc.viz.meshcat_server --parent-pid PID     # prints zmq_url=... and web_url=...
"""

from __future__ import annotations

import argparse
import ctypes
import os
import signal
import subprocess
import sys
import tempfile

from mbc.errors import MbcError

LOOPBACK = "127.0.0.1"
_PR_SET_PDEATHSIG = 1


def _die_with_parent(parent_pid: int) -> None:
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the periodic check below still ends the server
        pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        sys.exit(0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parent-pid", type=int, required=True)
    args = parser.parse_args()
    _die_with_parent(args.parent_pid)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))

    import tornado.ioloop
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LoopbackBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kwargs: listen(port, address=LOOPBACK, **kwargs)
            return app

    bridge = LoopbackBridge(host=LOOPBACK)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    tornado.ioloop.PeriodicCallback(lambda: os.getppid() != args.parent_pid and sys.exit(0), 500).start()
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


def start_server() -> tuple[subprocess.Popen, str, str]:
    """Start the server for this process; returns (process, zmq_url, web_url)."""
    errors = tempfile.TemporaryFile(mode="w+")  # not a pipe: nobody reads it while the server runs
    process = subprocess.Popen([sys.executable, "-u", "-m", "mbc.viz.meshcat_server", "--parent-pid", str(os.getpid())],
                               stdout=subprocess.PIPE, stderr=errors, text=True)
    urls = {}
    while len(urls) < 2:
        line = process.stdout.readline().strip()
        if not line and process.poll() is not None:
            errors.seek(0)
            raise MbcError(f"the meshcat server exited with code {process.returncode}: {errors.read()}")
        key, _, value = line.partition("=")
        if key in ("zmq_url", "web_url"):
            urls[key] = value
    return process, urls["zmq_url"], urls["web_url"]


if __name__ == "__main__":
    main()
