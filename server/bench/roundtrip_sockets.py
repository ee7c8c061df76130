"""Read TCP_NODELAY on the server's end of a connection, from outside the server process.

The bench and the tests ask what the server's own socket says, not what it should say: Linux's
pidfd_getfd(2) (5.6+) copies a file descriptor of another process into this one (for a child
process or as root: ptrace access), and the copy shares the socket, so getsockopt on it reads the
server's setting. No hook in the server is needed.
"""

from __future__ import annotations

import ctypes
import os
import socket

_SYS_PIDFD_GETFD = 438  # the same number on every Linux architecture (the common syscall table)


def _pidfd_getfd(pidfd: int, fd: int) -> int:
    libc = ctypes.CDLL(None, use_errno=True)
    result = libc.syscall(_SYS_PIDFD_GETFD, pidfd, fd, 0)
    if result < 0:
        errno = ctypes.get_errno()
        raise OSError(errno, f"pidfd_getfd: {os.strerror(errno)}")
    return result


def peer_socket_nodelay(pid: int, peer: tuple) -> bool:
    """TCP_NODELAY of the TCP socket in process `pid` whose peer address is `peer` (this end's
    getsockname()). OSError when the kernel refuses to copy a descriptor; LookupError when the
    process has no such socket (yet: accept() may lag the client's connect by a moment)."""
    pidfd = os.pidfd_open(pid)
    try:
        for name in os.listdir(f"/proc/{pid}/fd"):
            try:
                if not os.readlink(f"/proc/{pid}/fd/{name}").startswith("socket:"):
                    continue
            except OSError:  # closed meanwhile
                continue
            sock = socket.socket(fileno=_pidfd_getfd(pidfd, int(name)))
            try:
                if sock.type != socket.SOCK_STREAM or sock.family not in (socket.AF_INET, socket.AF_INET6):
                    continue
                try:
                    if sock.getpeername() != peer:
                        continue
                except OSError:  # a listening socket has no peer
                    continue
                return bool(sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))
            finally:
                sock.close()
    finally:
        os.close(pidfd)
    raise LookupError(f"process {pid} has no TCP socket connected to {peer}")
