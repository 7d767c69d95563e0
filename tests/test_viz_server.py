"""The meshcat server the project starts: loopback only, and gone when its program ends, however it ends.

Checked on the sockets the kernel reports open (/proc/net/tcp*), not on the printed URL."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VIEWER_SCRIPT = "from mbc.viz import MeshcatViewer; import time; v = MeshcatViewer(); print('ready', flush=True); time.sleep(120)"

pytestmark = pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="needs Linux /proc")


def _listening_inodes() -> dict[int, tuple[str, int]]:
    """inode -> (address, port) of every listening TCP socket."""
    sockets = {}
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] != "0A":  # LISTEN
                continue
            address, port = fields[1].split(":")
            raw = bytes.fromhex(address)
            if width == 8:
                host = ".".join(str(b) for b in raw[::-1])
            else:  # four little-endian 32-bit words
                words = b"".join(raw[i:i + 4][::-1] for i in range(0, 16, 4))
                host = ":".join(words[i:i + 2].hex() for i in range(0, 16, 2))
            sockets[int(fields[9])] = (host, int(port, 16))
    return sockets


def _sockets_of(pid: int) -> list[tuple[str, int]]:
    inodes = _listening_inodes()
    found = []
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inode = int(target[8:-1])
            if inode in inodes:
                found.append(inodes[inode])
    return found


def _children(pid: int) -> list[int]:
    children = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            children.append(int(stat.parent.name))
    return children


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_viewer_server_listens_on_loopback_only_and_ends_with_its_program(how):
    program = subprocess.Popen([sys.executable, "-c", VIEWER_SCRIPT], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        lines = []
        while not lines or lines[-1] != "ready":
            lines.append(program.stdout.readline().strip())
        assert any(line.startswith("meshcat viewer at http://127.0.0.1:") for line in lines), lines
        servers = _children(program.pid)
        assert len(servers) == 1
        sockets = _sockets_of(servers[0])
        assert len(sockets) >= 2  # the web server and the zmq socket
        assert all(host == "127.0.0.1" for host, _ in sockets), sockets
        program.send_signal(how)
        program.wait(timeout=30)
        deadline = time.time() + 10
        while _alive(servers[0]) and time.time() < deadline:
            time.sleep(0.05)
        assert not _alive(servers[0]), f"the meshcat server outlived its program ({how.name})"
    finally:
        if program.poll() is None:
            program.kill()
