"""Issue 55.3: the web app says its address only once it accepts connections, so a user who opens it
at once is not refused."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]


def test_the_address_is_said_only_when_the_server_accepts_connections():
    from tamp_os.gui import free_port

    port = free_port()
    command = Path(sys.executable).with_name("tamp-os")
    proc = subprocess.Popen([str(command), "gui", "--no-browser", "--port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=dict(os.environ))
    try:
        line = proc.stdout.readline()
        assert line.startswith(f"TAMP-OS web app at http://127.0.0.1:{port}/"), line
        with socket.create_connection(("127.0.0.1", port), timeout=5) as conn:  # refused before the fix
            conn.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
            assert conn.recv(12).startswith(b"HTTP/1.1 200")
    finally:
        proc.terminate()
        proc.wait(timeout=20)
