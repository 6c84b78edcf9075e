"""The attack corpus: each hostile program ends in a clear error within its limit, the caller
survives, and nothing is written outside the scratch directory."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from procedura_brep.config import SandboxLimits
from procedura_brep.errors import CompileError
from procedura_brep.program.sandbox import CompileOptions

LAMP = (Path(__file__).parent / "lamp.py").read_text()
FAST = SandboxLimits(cpu_s=3, wall_s=8.0, address_space_bytes=3 * 1024**3, recursion=500)
CANARY = Path("/tmp/procedura_canary_should_not_exist")


def inject(body: str, where: str = "helpers") -> str:
    """The lamp program with ``body`` inserted at the start of a section."""
    marker = f"# === {where} ==="
    return LAMP.replace(marker, marker + "\n" + body + "\n")


def in_part(body: str) -> str:
    """The lamp program whose ``arm`` part runs ``body`` first."""
    return LAMP.replace("def arm():\n", "def arm():\n" + "".join(f"    {ln}\n" for ln in body.splitlines()))


# (id, program, substring the error must contain)
POLICY = [
    ("import_os", inject("import os"), "import os"),
    ("import_subprocess", inject("import subprocess"), "import subprocess"),
    ("import_socket", inject("from socket import socket"), "from socket import"),
    ("dunder_import", inject("m = __import__('os')"), "'__import__'"),
    ("globals_escape", inject("def f():\n    return 1\ng = f.__globals__"), "'__globals__'"),
    ("getattr_dunder", inject("g = getattr(part, '__globals__')"), "getattr"),
    ("class_walk", inject("s = ().__class__.__bases__[0].__subclasses__()"), "starting with '_'"),
    ("builtins_dict", inject("b = __builtins__"), "'__builtins__'"),
    ("open_passwd", inject("t = open('/etc/passwd').read()"), "'open'"),
    ("write_outside", inject(f"open('{CANARY}', 'w').write('x')"), "'open'"),
    ("eval_exec", inject("eval('1+1')"), "'eval'"),
    ("monkeypatch", inject("Box.volume = 1"), "assigning to the attribute"),
    ("env_key", inject("import os\nk = os.environ['OPENAI_API_KEY']"), "import os"),
    ("fork_bomb", inject("import os\nwhile True:\n    os.fork()"), "import os"),
    ("private_attr", inject("x = Box(1, 1, 1)._dim"), "'_dim'"),
    ("font_file", inject("t = Text('x', 5, font_path='/etc/passwd')"), "'font_path'"),
    ("generator_frames", inject("def g():\n    yield gen.gi_frame.f_back\ngen = g()\n"
                                "b = next(gen).f_globals['builtins']"), "frames, code and globals"),
    ("frame_walk", inject("def g():\n    yield 1\nfr = g().gi_frame"), "'gi_frame'"),
    ("class_mro", inject("m = Box.mro()"), "'mro'"),
    ("submodule_import", inject("from procedura_brep.program import runtime\n"
                                "t = runtime.builtins.open('/etc/hostname').read()"), "import *"),
    ("match_class_attrs", inject("class Probe:\n    pass\nmatch Probe():\n"
                                 "    case Probe(x=red):\n        pass"), "match statements"),
    ("format_fields", inject("t = ('{0.' + 'x}').format(part)"), "'format'"),
    ("private_import_name", inject("from math import _x"), "'_x'"),
]


@pytest.mark.parametrize("pid, src, needle", POLICY, ids=[p[0] for p in POLICY])
def test_policy_rejects_before_running(worker, pid, src, needle):
    t = time.monotonic()
    m = worker.compile(src, CompileOptions(limits=FAST))
    assert not m.ok
    assert any(needle in f.message and f.line for f in m.findings), [f.message for f in m.findings]
    assert time.monotonic() - t < FAST.wall_s
    assert not CANARY.exists()


def test_infinite_loop_hits_cpu_limit(worker):
    t = time.monotonic()
    with pytest.raises(CompileError, match="CPU time limit|wall-clock limit"):
        worker.compile(in_part("while True:\n    pass"), CompileOptions(limits=FAST))
    assert time.monotonic() - t < FAST.wall_s + 2


def test_memory_bomb_is_contained(worker):
    t = time.monotonic()
    try:
        m = worker.compile(in_part("x = [0] * (10 ** 10)"), CompileOptions(limits=FAST))
    except CompileError as exc:
        assert "memory" in str(exc).lower() or "killed" in str(exc).lower()
    else:
        assert any(f.part == "arm" and "MemoryError" in f.message for f in m.findings)
    assert time.monotonic() - t < FAST.wall_s + 2


def test_deep_recursion(worker):
    src = in_part("def down(n):\n    return down(n + 1)\ndown(0)")
    m = worker.compile(src, CompileOptions(limits=FAST))
    assert any(f.part == "arm" and "RecursionError" in f.message for f in m.findings)


def test_huge_boolean_loop_hits_a_limit(worker):
    src = in_part("s = Box(1, 1, 1)\nfor i in range(10 ** 7):\n    s = s + Pos(i * 0.5, 0, 0) * Box(1, 1, 1)")
    with pytest.raises(CompileError, match="limit"):
        worker.compile(src, CompileOptions(limits=FAST))


def test_occt_failure_is_a_finding_with_part_and_line(worker):
    src = in_part("b = Box(10, 10, 10)\nreturn fillet(b.edges(), radius=50)")
    m = worker.compile(src, CompileOptions(limits=FAST))
    f = next(f for f in m.findings if f.part == "arm")
    assert f.code == "part-exception"
    assert "fillet" in src.splitlines()[f.line - 1]


def test_env_is_stripped_of_credentials(worker, monkeypatch):
    from procedura_brep.program.sandbox import clean_env
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    monkeypatch.setenv("MY_SECRET_TOKEN", "x")
    env = clean_env()
    assert "OPENAI_API_KEY" not in env and "MY_SECRET_TOKEN" not in env


def test_caller_survives_and_worker_still_compiles(worker):
    with pytest.raises(CompileError):
        worker.compile(in_part("import_me = 1\nwhile True:\n    pass"), CompileOptions(limits=FAST))
    m = worker.compile(LAMP, CompileOptions(name="lamp"))
    assert m.ok and [p.name for p in m.parts] == ["base", "post", "arm"]


def test_warm_compile_is_fast(worker):
    worker.compile(LAMP)
    t = time.monotonic()
    worker.compile(LAMP)
    assert time.monotonic() - t < 5.0  # generous: a functional check, the benchmark has the figure


@pytest.mark.skipif(not hasattr(__import__("os"), "geteuid") or __import__("os").geteuid() != 0,
                    reason="the privilege drop applies when the worker runs as root")
def test_root_worker_children_drop_to_nobody(tmp_path):
    """A child of a root worker runs as nobody and cannot read root-only files."""
    import json
    import os
    import pwd

    from procedura_brep.config import SANDBOX
    from procedura_brep.program import worker
    secret = tmp_path / "secret"
    secret.write_text("root only")
    secret.chmod(0o600)
    scratch = tmp_path / "scratch"
    scratch.mkdir(mode=0o700)
    pid = os.fork()
    if pid == 0:
        try:
            from dataclasses import asdict
            worker._limit_child(asdict(SANDBOX), str(scratch), None)
            try:
                open(secret).read()
                leaked = True
            except PermissionError:
                leaked = False
            with open("probe.json", "w") as fh:  # the cwd is the scratch dir
                json.dump({"uid": os.getuid(), "leaked": leaked}, fh)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    probe = json.loads((scratch / "probe.json").read_text())
    assert probe == {"uid": pwd.getpwnam("nobody").pw_uid, "leaked": False}
