"""Operating-system isolation of a compile child (Linux), applied after the resource limits
and before any program code runs. Standard library only (``ctypes`` on libc): no new native
dependencies, and every layer is best effort: one the kernel refuses is skipped, and
:func:`isolate` says which layers applied and which did not.

Layers (:data:`LAYERS`):
  * ``netns``: a fresh, empty network namespace (only a down loopback): with root
    ``unshare(CLONE_NEWNET)``, otherwise ``unshare(CLONE_NEWUSER | CLONE_NEWNET)`` where
    unprivileged user namespaces are enabled.
  * ``no_new_privs``: ``prctl(PR_SET_NO_NEW_PRIVS)``; no later exec can gain privileges
    (set-uid binaries), and it lets an unprivileged process install the next two layers.
  * ``landlock``: file access only beneath the folders the compile needs (Linux >= 5.13, no
    privileges needed): read-only in the Python prefixes, the import path, the system library
    and font folders (:data:`SYSTEM_READ`) and the part cache; read-write only in the scratch
    dir; no exec anywhere. Landlock also forbids mounts and, with ABI 6 (Linux >= 6.12),
    signals to processes outside the sandbox and abstract unix sockets; with ABI 4 (Linux >=
    6.7), TCP bind and connect.
  * ``seccomp``: a classic-BPF filter that makes ``socket``, ``socketpair``, ``execve``,
    ``execveat`` and ``unshare`` fail with EPERM, refuses new processes (``fork``, ``vfork``,
    ``clone`` without ``CLONE_THREAD``: EPERM) while threads still start (``clone3`` fails with
    ENOSYS, whose flags a filter cannot read, so libc falls back to ``clone``), and refuses
    foreign-architecture and x32 system calls (which would bypass the numbers); x86_64 and
    aarch64.
The privilege drop (a distinct unprivileged uid per compile when the worker runs as root) is
in :mod:`procedura_brep.program.worker`. A mount namespace is not used: Landlock already
confines every open to the folders above without root or user namespaces, and it forbids
mounts, so a private mount tree would add nothing (docs/program-format.md, Security).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
import platform
import struct
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field

PR_SET_NO_NEW_PRIVS = 38
PR_SET_SECCOMP = 22
SECCOMP_MODE_FILTER = 2
SECCOMP_RET_ALLOW = 0x7FFF0000
SECCOMP_RET_ERRNO = 0x00050000
CLONE_NEWUSER = 0x10000000
CLONE_NEWNET = 0x40000000
CLONE_THREAD = 0x00010000
X32_SYSCALL_BIT = 0x40000000


@dataclass(frozen=True)
class Arch:
    """System-call numbers of one architecture."""

    audit: int
    denied: tuple[int, ...]   # socket, socketpair, execve, execveat, unshare (+ fork, vfork)
    clone: int
    clone3: int
    x32: bool = False


ARCHES = {
    "x86_64": Arch(0xC000003E, (41, 53, 59, 322, 272, 57, 58), clone=56, clone3=435, x32=True),
    "aarch64": Arch(0xC00000B7, (198, 199, 221, 281, 97), clone=220, clone3=435),
}
#: landlock_create_ruleset, landlock_add_rule, landlock_restrict_self (the generic table:
#: the same numbers on x86_64 and aarch64).
SYS_LANDLOCK = (444, 445, 446)
LANDLOCK_CREATE_RULESET_VERSION = 1
LANDLOCK_RULE_PATH_BENEATH = 1
#: Landlock file-system rights (bit i), by name; REFER needs ABI 2, TRUNCATE 3, IOCTL_DEV 5.
FS = {name: 1 << i for i, name in enumerate((
    "execute", "write_file", "read_file", "read_dir", "remove_dir", "remove_file", "make_char",
    "make_dir", "make_reg", "make_sock", "make_fifo", "make_block", "make_sym", "refer",
    "truncate", "ioctl_dev"))}
_FILE_RIGHTS = FS["execute"] | FS["write_file"] | FS["read_file"] | FS["truncate"] | FS["ioctl_dev"]
READ = FS["read_file"] | FS["read_dir"]
WRITE = (READ | FS["write_file"] | FS["remove_dir"] | FS["remove_file"] | FS["make_dir"]
         | FS["make_reg"] | FS["refer"] | FS["truncate"])
#: Net rights (ABI 4) and scopes (ABI 6), all handled and none granted.
NET_ALL = 0b11            # bind_tcp, connect_tcp
SCOPE_ALL = 0b11          # abstract unix sockets, signals
#: Read-only system folders a compile may need (libraries loaded late, fonts for ``Text``,
#: the CPU list libc reads for the thread count, the child's own ``/proc/<pid>``: ``/proc/self``
#: is resolved when the rule is made). Missing ones are skipped.
SYSTEM_READ = ("/usr/lib", "/usr/lib64", "/usr/local/lib", "/lib", "/lib64", "/usr/share/fonts",
               "/usr/local/share/fonts", "/etc/fonts", "/etc/ld.so.cache", "/sys/devices/system/cpu",
               "/proc/self")
#: Device files opened read-write.
DEVICES = ("/dev/null", "/dev/zero", "/dev/urandom")
#: Every layer :func:`isolate` tries, in order (``own_uid`` is the worker's, as root).
LAYERS = ("netns", "no_new_privs", "landlock", "seccomp")
_LD_W_ABS, _JEQ_K, _JGE_K, _JSET_K, _RET_K = 0x20, 0x15, 0x35, 0x45, 0x06


@dataclass
class Layers:
    """What :func:`isolate` applied (``applied``) and what it could not (``missing``)."""

    applied: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)

    def line(self) -> str:
        """``applied: a b c; not applied: d`` (``-`` for none)."""
        return (f"applied: {' '.join(self.applied) or '-'}; "
                f"not applied: {' '.join(self.missing) or '-'}")


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
            lib = _libc()
            lib.syscall.restype = ctypes.c_long
        except OSError:
            pass


def _filter(arch: Arch) -> bytes:
    """The BPF program: allow everything but the denied calls, new processes and foreign ABIs."""
    ALLOW, DENY, NOSYS = "allow", "deny", "nosys"  # labels of the three final returns
    prog: list[tuple[int, int | str, int | str, int]] = [
        (_LD_W_ABS, 0, 0, 4),                    # A = arch
        (_JEQ_K, 0, DENY, arch.audit),           # foreign arch -> deny
        (_LD_W_ABS, 0, 0, 0),                    # A = syscall nr
    ]
    if arch.x32:
        prog.append((_JGE_K, DENY, 0, X32_SYSCALL_BIT))  # x32 ABI -> deny
    prog += [(_JEQ_K, DENY, 0, nr) for nr in arch.denied]
    prog.append((_JEQ_K, NOSYS, 0, arch.clone3))  # libc then uses clone, whose flags we see
    prog.append((_JEQ_K, 0, ALLOW, arch.clone))
    prog.append((_LD_W_ABS, 0, 0, 16))           # A = low word of clone's flags (args[0])
    prog.append((_JSET_K, ALLOW, DENY, CLONE_THREAD))  # a thread, or a new process
    labels = {ALLOW: len(prog), DENY: len(prog) + 1, NOSYS: len(prog) + 2}
    prog.append((_RET_K, 0, 0, SECCOMP_RET_ALLOW))
    prog.append((_RET_K, 0, 0, SECCOMP_RET_ERRNO | errno.EPERM))
    prog.append((_RET_K, 0, 0, SECCOMP_RET_ERRNO | errno.ENOSYS))

    def rel(i: int, j: int | str) -> int:
        return labels[j] - i - 1 if isinstance(j, str) else j

    return b"".join(struct.pack("HBBI", c, rel(i, jt), rel(i, jf), k)
                    for i, (c, jt, jf, k) in enumerate(prog))


def _no_new_privs(libc: ctypes.CDLL) -> bool:
    return bool(libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) == 0)


def _seccomp(libc: ctypes.CDLL) -> bool:
    machine = platform.machine()
    if machine not in ARCHES:
        return False
    code = _filter(ARCHES[machine])
    buf = ctypes.create_string_buffer(code, len(code))

    class SockFprog(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    prog = SockFprog(len(code) // 8, ctypes.cast(buf, ctypes.c_void_p))
    return bool(libc.prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, ctypes.byref(prog), 0, 0) == 0)


def _netns(libc: ctypes.CDLL) -> bool:
    flags = CLONE_NEWNET if os.geteuid() == 0 else CLONE_NEWUSER | CLONE_NEWNET
    return bool(libc.unshare(flags) == 0)


def landlock_abi(libc: ctypes.CDLL | None = None) -> int:
    """The kernel's Landlock ABI version (0: not available)."""
    if platform.system() != "Linux":
        return 0
    libc = libc or _libc()
    libc.syscall.restype = ctypes.c_long
    v = libc.syscall(SYS_LANDLOCK[0], None, ctypes.c_size_t(0),
                     ctypes.c_uint32(LANDLOCK_CREATE_RULESET_VERSION))
    return max(int(v), 0)


def _handled_fs(abi: int) -> int:
    rights = (1 << 13) - 1  # ABI 1: execute .. make_sym
    if abi >= 2:
        rights |= FS["refer"]
    if abi >= 3:
        rights |= FS["truncate"]
    if abi >= 5:
        rights |= FS["ioctl_dev"]
    return rights


def read_paths(extra: Iterable[str] = ()) -> list[str]:
    """The folders (and files) a compile child may read: the Python prefixes, every import
    path entry but the current directory, this package, :data:`SYSTEM_READ` and ``extra``."""
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    cwd = os.getcwd()
    paths = [sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, here,
             *(p for p in sys.path if p and os.path.abspath(p) != cwd), *SYSTEM_READ, *extra]
    return list(dict.fromkeys(os.path.abspath(p) for p in paths))


def _landlock(libc: ctypes.CDLL, *, write: Iterable[str], read: Iterable[str],
              read_fds: Iterable[int]) -> bool:
    """Restrict this process's file access to ``write`` (read-write), ``read`` and
    ``read_fds`` (read-only) and :data:`DEVICES`; returns whether it applied."""
    abi = landlock_abi(libc)
    if abi < 1:
        return False
    handled = _handled_fs(abi)
    attr = struct.pack("QQQ", handled, NET_ALL if abi >= 4 else 0, SCOPE_ALL if abi >= 6 else 0)
    size = 8 if abi < 4 else 16 if abi < 6 else 24
    buf = ctypes.create_string_buffer(attr[:size], size)
    ruleset = int(libc.syscall(SYS_LANDLOCK[0], buf, ctypes.c_size_t(size), ctypes.c_uint32(0)))
    if ruleset < 0:
        return False
    try:
        def add(fd: int, rights: int) -> None:
            import stat
            if not stat.S_ISDIR(os.fstat(fd).st_mode):
                rights &= _FILE_RIGHTS
            rule = ctypes.create_string_buffer(struct.pack("=Qi", rights & handled, fd), 12)
            libc.syscall(SYS_LANDLOCK[1], ctypes.c_int(ruleset),
                         ctypes.c_int(LANDLOCK_RULE_PATH_BENEATH), rule, ctypes.c_uint32(0))

        def add_path(path: str, rights: int) -> None:
            try:
                fd = os.open(path, os.O_PATH | os.O_CLOEXEC)
            except OSError:
                return  # a folder this system does not have
            try:
                add(fd, rights)
            finally:
                os.close(fd)

        for p in write:
            add_path(p, WRITE)
        for p in DEVICES:
            add_path(p, FS["read_file"] | FS["write_file"])
        for p in read:
            add_path(p, READ)
        for fd in read_fds:
            add(fd, READ)
        return bool(libc.syscall(SYS_LANDLOCK[2], ctypes.c_int(ruleset), ctypes.c_uint32(0)) == 0)
    finally:
        os.close(ruleset)


def isolate(*, network: bool = True, syscalls: bool = True, files: bool = True,
            scratch: str | None = None, read: Iterable[str] = (),
            read_fds: Iterable[int] = ()) -> Layers:
    """Apply every available layer to this process; returns which applied and which did not.

    Call in the compile child after the resource limits, while it is still single-threaded
    (the filters cover threads created later). The network namespace comes first: as a
    non-root user it needs a new user namespace, which seccomp then refuses. ``scratch`` is
    the one folder that stays writable (the current directory when None); ``read`` and
    ``read_fds`` are folders readable besides :func:`read_paths` (the part cache).
    """
    wanted = [n for n, on in zip(LAYERS, (network, True, files, syscalls)) if on]
    out = Layers()
    if platform.system() == "Linux":
        try:
            libc = _libc()
        except OSError:
            libc = None
        if libc is not None:
            if network and _netns(libc):
                out.applied.append("netns")
            if _no_new_privs(libc):
                out.applied.append("no_new_privs")
                if files and _landlock(libc, write=[scratch or os.getcwd()],
                                       read=read_paths(read), read_fds=read_fds):
                    out.applied.append("landlock")
                if syscalls and _seccomp(libc):
                    out.applied.append("seccomp")
    out.missing = [n for n in wanted if n not in out.applied]
    return out


def probe() -> Layers:
    """The layers a compile child gets on this machine: forks a child that applies them to
    itself (in a temporary scratch dir) and reports back; ``own_uid`` is added when this
    process runs as root (the worker's children then drop to their own uid)."""
    import json
    import tempfile
    if platform.system() != "Linux":
        return Layers([], [*LAYERS])
    with tempfile.TemporaryDirectory(prefix="procedura-probe-") as scratch:
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child reports through the pipe
            try:
                os.close(r)
                res = isolate(scratch=scratch)
                os.write(w, json.dumps(res.__dict__).encode())
            finally:
                os._exit(0)
        os.close(w)
        with os.fdopen(r, "rb") as fh:
            data = fh.read()
        os.waitpid(pid, 0)
    try:
        res = Layers(**json.loads(data))
    except (ValueError, TypeError):
        res = Layers([], [*LAYERS])
    (res.applied if os.geteuid() == 0 else res.missing).append("own_uid")
    return res
