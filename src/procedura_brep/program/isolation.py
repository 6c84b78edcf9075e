"""Operating-system isolation of a compile child (Linux), applied after the resource limits
and before any program code runs. Standard library only (``ctypes`` on libc): no new native
dependencies, and every layer is best effort: one the kernel refuses is skipped, and
:func:`isolate` returns the layers that did apply.

Layers:
  * ``no_new_privs``: ``prctl(PR_SET_NO_NEW_PRIVS)``; no later exec can gain privileges
    (set-uid binaries), and it lets an unprivileged process install the seccomp filter.
  * ``seccomp``: a classic-BPF filter that makes ``socket``, ``socketpair``, ``execve`` and
    ``execveat`` fail with EPERM (and refuses foreign-architecture and x32 system calls, which
    would bypass the syscall numbers); x86_64 and aarch64.
  * ``netns``: a fresh, empty network namespace (only a down loopback): with root
    ``unshare(CLONE_NEWNET)``, otherwise ``unshare(CLONE_NEWUSER | CLONE_NEWNET)`` where
    unprivileged user namespaces are enabled.
The privilege drop (a distinct unprivileged uid per compile when the worker runs as root) is
in :mod:`procedura_brep.program.worker`.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
import platform
import struct

PR_SET_NO_NEW_PRIVS = 38
PR_SET_SECCOMP = 22
SECCOMP_MODE_FILTER = 2
SECCOMP_RET_ALLOW = 0x7FFF0000
SECCOMP_RET_ERRNO = 0x00050000
CLONE_NEWUSER = 0x10000000
CLONE_NEWNET = 0x40000000
X32_SYSCALL_BIT = 0x40000000
#: (audit arch, denied syscall numbers: socket, socketpair, execve, execveat)
ARCHES = {
    "x86_64": (0xC000003E, (41, 53, 59, 322)),
    "aarch64": (0xC00000B7, (198, 199, 221, 281)),
}
_LD_W_ABS, _JEQ_K, _JGE_K, _RET_K = 0x20, 0x15, 0x35, 0x06


_LIBC: list[ctypes.CDLL] = []


def _libc() -> ctypes.CDLL:
    """libc, loaded once (the worker preloads it: ``find_library`` may run ``ldconfig``)."""
    if not _LIBC:
        try:
            _LIBC.append(ctypes.CDLL("libc.so.6", use_errno=True))
        except OSError:
            _LIBC.append(ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True))
    return _LIBC[0]


def preload() -> None:
    """Load libc in the zygote, so a child has nothing to look up."""
    if platform.system() == "Linux":
        try:
            _libc()
        except OSError:
            pass


def _filter(arch: int, denied: tuple[int, ...], x32: bool) -> bytes:
    """The BPF program: allow everything but ``denied`` (and foreign ABIs)."""
    DENY = -1  # placeholder: jump to the final "deny" instruction
    prog: list[tuple[int, int, int, int]] = [
        (_LD_W_ABS, 0, 0, 4),                    # A = arch
        (_JEQ_K, 0, DENY, arch),                 # foreign arch -> deny
        (_LD_W_ABS, 0, 0, 0),                    # A = syscall nr
    ]
    if x32:
        prog.append((_JGE_K, DENY, 0, X32_SYSCALL_BIT))  # x32 ABI -> deny
    prog += [(_JEQ_K, DENY, 0, nr) for nr in denied]
    prog.append((_RET_K, 0, 0, SECCOMP_RET_ALLOW))
    prog.append((_RET_K, 0, 0, SECCOMP_RET_ERRNO | errno.EPERM))
    last = len(prog) - 1
    fixed = [(c, last - i - 1 if jt == DENY else jt, last - i - 1 if jf == DENY else jf, k)
             for i, (c, jt, jf, k) in enumerate(prog)]
    return b"".join(struct.pack("HBBI", *ins) for ins in fixed)


def _no_new_privs(libc: ctypes.CDLL) -> bool:
    return libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) == 0


def _seccomp(libc: ctypes.CDLL) -> bool:
    machine = platform.machine()
    if machine not in ARCHES:
        return False
    arch, denied = ARCHES[machine]
    code = _filter(arch, denied, x32=machine == "x86_64")
    buf = ctypes.create_string_buffer(code, len(code))

    class SockFprog(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    prog = SockFprog(len(code) // 8, ctypes.cast(buf, ctypes.c_void_p))
    return libc.prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, ctypes.byref(prog), 0, 0) == 0


def _netns(libc: ctypes.CDLL) -> bool:
    flags = CLONE_NEWNET if os.geteuid() == 0 else CLONE_NEWUSER | CLONE_NEWNET
    return libc.unshare(flags) == 0


def isolate(*, network: bool = True, syscalls: bool = True) -> list[str]:
    """Apply every available layer to this process; returns the names of those applied.

    Call in the compile child after the resource limits, while it is still single-threaded
    (the seccomp filter covers threads created later). The network namespace comes first:
    as a non-root user it needs a new user namespace, which seccomp does not block.
    """
    if not platform.system() == "Linux":
        return []
    try:
        libc = _libc()
    except OSError:
        return []
    applied: list[str] = []
    if network and _netns(libc):
        applied.append("netns")
    if _no_new_privs(libc):
        applied.append("no_new_privs")
        if syscalls and _seccomp(libc):
            applied.append("seccomp")
    return applied
