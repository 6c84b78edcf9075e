"""The OS layers of a compile child, each tested by its own hostile program.

The policy stops these programs long before they run, so :class:`EscapedWorker` plays a
program that got past it: a real compile worker (zygote, limits, scratch dir, isolation
layers, uid drop, the parent's validating reader) whose AST policy is off, with ``open``
among the builtins and ``os`` / ``socket`` / ``threading`` importable. What the program then
tries must end as a clean finding (``part-exception`` naming the OS error), never a file
written, read or a process started.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from procedura_brep.errors import CompileError
from procedura_brep.program import isolation
from procedura_brep.program.sandbox import CompileOptions, Worker, clean_env

pytestmark = pytest.mark.skipif(platform.system() != "Linux", reason="Linux isolation layers")
ROOT = os.geteuid() == 0
LAMP = (Path(__file__).parent / "lamp.py").read_text()
LANDLOCK = isolation.landlock_abi() >= 1


def in_arm(body: str) -> str:
    """The lamp whose ``arm`` part runs ``body`` first."""
    return LAMP.replace("def arm():\n", "def arm():\n" + "".join(f"    {ln}\n" for ln in body.splitlines()))


#: A compile worker whose children run programs that got past the Python layers: the AST
#: policy off, ``open`` among the builtins, ``os``, ``socket``, ``threading``, ``ctypes``
#: importable. Everything else (the zygote, the limits, the OS layers, the reader of the
#: child's result) is the real one.
ESCAPED_WORKER = """
from procedura_brep.program import allowlist as policy, runtime
policy.check = lambda *a, **k: None
policy.ALLOWED_IMPORTS |= {"os", "socket", "threading", "ctypes"}
runtime.SAFE_BUILTINS += ("open",)
from procedura_brep.program.worker import main
main()
"""


class EscapedWorker(Worker):
    """:class:`Worker` running :data:`ESCAPED_WORKER` (a fresh process, like the real zygote:
    forking the test process itself can deadlock on a lock one of its threads held)."""

    def start(self) -> "EscapedWorker":
        if self._proc is None or self._proc.poll() is not None:
            self._proc = subprocess.Popen(
                [sys.executable, "-P", "-c", ESCAPED_WORKER], stdin=subprocess.PIPE,
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=clean_env(),
                cwd=tempfile.gettempdir())
            self._ready = False
        return self


@pytest.fixture(scope="module")
def escaped_worker():
    w = EscapedWorker()
    yield w
    w.close()


def escaped(w: EscapedWorker, body: str, *, cache: bool = False) -> tuple[list, list[str]]:
    """Compile the lamp whose arm runs ``body`` in ``w``; returns ``(error findings, layers
    applied)``."""
    try:
        model = w.compile(in_arm(body), CompileOptions(name="lamp", cache=cache))
        errors = [f for f in model.findings if f.severity == "error"]
    except CompileError as exc:
        errors = exc.findings
    layers = w.isolation.split(";")[0].removeprefix("applied:").split()
    return errors, layers


def _one_arm_error(errors: list, *needles: str) -> str:
    assert len(errors) == 1 and errors[0].code == "part-exception" and errors[0].part == "arm", errors
    msg = errors[0].message
    assert all(n in msg for n in needles), msg
    assert "\n" not in msg and len(msg) < 2000
    return msg


def _open_folder() -> Path:
    """A new folder in /tmp that every user may reach and write."""
    d = Path(tempfile.mkdtemp(prefix="procedura-test-"))
    d.chmod(0o777)
    return d


@pytest.fixture()
def outside():
    """A folder outside the scratch dir that every user may write, and a file every user may
    read: only Landlock (not the uid) stands between the child and them."""
    d = _open_folder()
    (d / "readable.txt").write_text("not for programs")
    (d / "readable.txt").chmod(0o644)
    yield d
    shutil.rmtree(d, ignore_errors=True)


def test_a_clean_program_compiles_under_every_layer(escaped_worker):
    """The control: threads still start (``clone3`` -> ENOSYS, libc falls back to ``clone``
    with CLONE_THREAD), and the lamp compiles with every layer applied."""
    body = "import threading\nt = threading.Thread(target=math.sqrt, args=(4.0,))\nt.start()\nt.join()"
    errors, layers = escaped(escaped_worker, body)
    assert errors == []
    assert {"no_new_privs", "seccomp"} <= set(layers)
    assert ("landlock" in layers) == LANDLOCK and ("own_uid" in layers) == ROOT


@pytest.mark.skipif(not LANDLOCK, reason="this kernel has no Landlock")
def test_landlock_refuses_a_write_outside_the_scratch_dir(escaped_worker, outside):
    errors, _ = escaped(escaped_worker, f"open({str(outside / 'escape.txt')!r}, 'w').write('x')")
    _one_arm_error(errors, "PermissionError", "Permission denied")
    assert not (outside / "escape.txt").exists()


@pytest.mark.skipif(not LANDLOCK, reason="this kernel has no Landlock")
def test_landlock_refuses_a_write_in_tmp(escaped_worker):
    target = f"/tmp/procedura-escape-{os.getpid()}.txt"
    try:
        errors, _ = escaped(escaped_worker, f"open({target!r}, 'w').write('x')")
        _one_arm_error(errors, "PermissionError")
        assert not os.path.exists(target)
    finally:
        if os.path.exists(target):
            os.unlink(target)


@pytest.mark.skipif(not LANDLOCK, reason="this kernel has no Landlock")
def test_landlock_refuses_a_read_outside_the_library_folders(escaped_worker, outside):
    for path in (outside / "readable.txt", "/etc/hostname"):
        errors, _ = escaped(escaped_worker, f"open({str(path)!r}).read()")
        _one_arm_error(errors, "PermissionError")


def test_seccomp_refuses_a_fork(escaped_worker):
    body = "import os\npid = os.fork()\nif pid == 0:\n    os._exit(0)"
    errors, _ = escaped(escaped_worker, body)
    _one_arm_error(errors, "PermissionError", "Operation not permitted")


UNSHARE = """import ctypes
import os
libc = ctypes.CDLL(None, use_errno=True)
if libc.unshare(0x10000000) != 0:
    raise ValueError(f"unshare: {os.strerror(ctypes.get_errno())}")"""


def test_seccomp_refuses_sockets_exec_and_namespaces(escaped_worker):
    for body in ("import socket\nsocket.socket()", "import os\nos.execv('/bin/true', ['true'])",
                 UNSHARE):
        errors, _ = escaped(escaped_worker, body)
        _one_arm_error(errors, "Operation not permitted")


def test_private_network_namespace(escaped_worker):
    parent_net = os.readlink("/proc/self/ns/net")
    body = f"if os.readlink('/proc/self/ns/net') == {parent_net!r}:\n    raise ValueError('shared netns')"
    errors, layers = escaped(escaped_worker, "import os\n" + body)
    if not ROOT and "netns" not in layers:
        pytest.skip("this kernel refuses unprivileged user namespaces")
    assert "netns" in layers and errors == []


@pytest.mark.skipif(not ROOT, reason="the uid switch applies when the worker runs as root")
def test_own_uid_refuses_a_root_only_file_in_a_readable_folder(escaped_worker):
    """The secret lies in the part cache, which Landlock lets the child read: only the uid
    switch keeps it out."""
    escaped_worker.start()._ensure_ready()  # makes the cache folder (0o755)
    cache = Path(escaped_worker.cache_dir)
    (cache / "secret").write_text("root only")
    (cache / "secret").chmod(0o600)
    body = (f"if os.getuid() == 0:\n    raise ValueError('still root')\n"
            f"open({str(cache / 'secret')!r}).read()")
    errors, layers = escaped(escaped_worker, "import os\n" + body, cache=True)
    assert "own_uid" in layers
    _one_arm_error(errors, "PermissionError")


@pytest.mark.skipif(not ROOT, reason="simulates a normal user by switching uid, which needs root")
def test_layers_as_a_normal_user(outside):
    """As a normal user (no root): no-new-privs, Landlock and seccomp apply, the network
    namespace where unprivileged user namespaces are enabled; the scratch dir stays writable
    and nothing outside it."""
    scratch = outside / "scratch"
    scratch.mkdir(mode=0o777)
    scratch.chmod(0o777)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            os.setgroups([])
            os.setgid(12345)
            os.setuid(12345)
            layers = isolation.isolate(scratch=str(scratch))
            res: dict = {"layers": layers.applied, "missing": layers.missing}
            for key, fn in (("socket", socket.socket), ("fork", os.fork),
                            ("outside", lambda: open(outside / "escape.txt", "w")),
                            ("inside", lambda: open(scratch / "ok.txt", "w").close())):
                try:
                    fn()
                    res[key] = "ok"
                except OSError as exc:
                    res[key] = exc.errno
            os.write(w, json.dumps(res).encode())
        finally:
            os._exit(0)
    os.close(w)
    os.waitpid(pid, 0)
    res = json.loads(os.read(r, 4096))
    assert {"no_new_privs", "seccomp"} <= set(res["layers"]) and res["socket"] == 1
    assert res["fork"] == 1 and res["inside"] == "ok"
    if LANDLOCK:
        assert "landlock" in res["layers"] and res["outside"] == 13


def test_probe_says_which_layers_apply():
    res = isolation.probe()
    assert set(res.applied) | set(res.missing) == {*isolation.LAYERS, "own_uid"}
    assert not set(res.applied) & set(res.missing)
    assert ("landlock" in res.applied) == LANDLOCK and ("own_uid" in res.applied) == ROOT
    assert res.line().startswith("applied: ")


def test_doctor_names_the_layers():
    from procedura_brep.doctor import _isolation
    res, check = isolation.probe(), _isolation()
    assert check.detail == res.line() and check.ok == (not res.missing) and check.optional


def test_the_worker_records_the_layers_of_its_last_child():
    from procedura_brep.program.sandbox import CompileOptions, Worker
    w = Worker()
    try:
        model = w.compile(LAMP, CompileOptions(name="lamp", cache=False))
    finally:
        w.close()
    assert model.ok and w.isolation == isolation.probe().line()
