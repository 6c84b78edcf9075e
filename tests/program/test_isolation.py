"""The OS layers of a compile child, each tested by its own hostile probe run after the
child's real set-up (``worker._limit_child``): the policy stops these programs long before,
so the probes call the system directly, as an escaped program would."""

from __future__ import annotations

import json
import os
import platform
import socket
from dataclasses import asdict

import pytest

from procedura_brep.config import SANDBOX
from procedura_brep.program import worker

pytestmark = pytest.mark.skipif(platform.system() != "Linux", reason="Linux isolation layers")
ROOT = os.geteuid() == 0


def _probe(scratch) -> dict:
    """Fork a child, set it up exactly like a compile child, and try each escape."""
    secret = scratch.parent / "secret"
    secret.write_text("root only")
    secret.chmod(0o600)
    parent_net = os.readlink("/proc/self/ns/net")
    pid = os.fork()
    if pid == 0:
        res: dict = {}
        try:
            worker._limit_child(asdict(SANDBOX), str(scratch), None)
            try:
                socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                res["socket"] = "opened"
            except OSError as exc:
                res["socket"] = exc.errno
            try:
                os.execv("/bin/true", ["true"])
            except OSError as exc:
                res["exec"] = exc.errno
            try:
                open(secret).read()
                res["secret"] = "read"
            except OSError as exc:
                res["secret"] = exc.errno
            res["net_ns_shared"] = os.readlink("/proc/self/ns/net") == parent_net
            status = open("/proc/self/status").read()
            res["no_new_privs"] = "NoNewPrivs:\t1" in status
            res["uid"], res["pid"] = os.getuid(), os.getpid()
            with open("probe.json", "w") as fh:  # the cwd is the scratch dir
                json.dump(res, fh)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    res = json.loads((scratch / "probe.json").read_text())
    log = (scratch / "child.log").read_text()
    res["layers"] = next(ln for ln in log.splitlines() if ln.startswith("isolation:")).split()[1:]
    return res


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    scratch = tmp_path_factory.mktemp("iso") / "scratch"
    scratch.mkdir(mode=0o700)
    return _probe(scratch)


def test_seccomp_denies_sockets(probe):
    assert probe["socket"] == 1  # EPERM


def test_seccomp_denies_exec(probe):
    assert probe["exec"] == 1


def test_no_new_privs(probe):
    assert probe["no_new_privs"] is True


def test_private_network_namespace(probe):
    if not ROOT and "netns" not in probe["layers"]:
        pytest.skip("this kernel refuses unprivileged user namespaces")
    assert "netns" in probe["layers"] and probe["net_ns_shared"] is False


def test_child_log_names_every_layer(probe):
    expected = {"no_new_privs", "seccomp"} | ({"netns", "own_uid"} if ROOT else set())
    assert expected <= set(probe["layers"])


@pytest.mark.skipif(not ROOT, reason="the uid switch applies when the worker runs as root")
def test_root_worker_child_runs_as_its_own_uid_and_cannot_read_root_files(probe):
    assert probe["uid"] == worker.child_uid(probe["pid"]) and probe["uid"] != 0
    assert probe["secret"] == 13  # EACCES


@pytest.mark.skipif(not ROOT, reason="simulates a normal user by switching uid, which needs root")
def test_layers_as_a_normal_user(tmp_path):
    """As a normal user (no root): no-new-privs and seccomp apply, the network namespace where
    unprivileged user namespaces are enabled; files stay writable."""
    from procedura_brep.program import isolation
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            os.setgroups([])
            os.setgid(12345)
            os.setuid(12345)
            layers = isolation.isolate()
            try:
                socket.socket()
                sock = "opened"
            except OSError as exc:
                sock = exc.errno
            os.write(w, json.dumps({"layers": layers, "socket": sock}).encode())
        finally:
            os._exit(0)
    os.close(w)
    os.waitpid(pid, 0)
    res = json.loads(os.read(r, 4096))
    assert {"no_new_privs", "seccomp"} <= set(res["layers"]) and res["socket"] == 1
