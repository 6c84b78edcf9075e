"""The fixer's conversation sends only the newest render's images (issue 23.6: every earlier
render's PNGs were resent with each fixer call, 12 PNGs where 6 were new); earlier render
observations keep their text and say how many views were left out. The reference image stays."""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.agent.actions import CompileOutcome
from procedura_brep.agent.critic import parse_critique
from procedura_brep.agent.refine import RefineBench, refine
from procedura_brep.llm import Image

PNG = b"\x89PNG\r\n\x1a\n"  # the signature is all a stand-in needs


class _Bench(RefineBench):
    """Renders are tagged PNG stand-ins; the critic and the gates are canned."""

    def render(self, source, *, views, close_up):
        self.last_images = [Image(PNG + f"{source}:{v}".encode(), v) for v in views]
        self.last_legend = "body #ff0000"
        return self.last_images

    def critique(self, source, views, trail):
        self.host.call("critic", "", [], max_tokens=10)
        return parse_critique("SUMMARY: fine\nISSUES: none")

    def compile(self, source):
        return CompileOutcome(True)


class _Host:
    def __init__(self, out_dir: Path, replies: list[dict]) -> None:
        self.tools, self.name, self.prompt, self.out_dir = None, "m", "a thing", out_dir
        self.replies = [json.dumps(r) for r in replies]
        self.requests: list[list] = []
        self.reference = Image(PNG + b"reference", "reference")

    def call(self, role, system, messages, *, max_tokens=8000):
        if role == "critic":
            return ""
        self.requests.append(list(messages))
        return self.replies.pop(0)

    def refs(self):
        return [self.reference]

    def progress(self, stage, text):
        pass


def test_only_the_newest_render_is_sent_with_earlier_views_noted(tmp_path):
    host = _Host(tmp_path, [{"action": "render", "views": ["iso_ne", "front"]},
                            {"action": "render", "views": ["left", "top", "front"]},
                            {"action": "diagnose"},
                            {"action": "finish", "verdict": "ok"}])
    _, report = refine(host, "p0", intro="refine this", max_edits=2, max_actions=10, bench_type=_Bench)
    assert report["verdict"] == "ok" and not host.replies
    second, third = host.requests[1], host.requests[2]
    # the call after the first render carries its two views (and the reference)
    assert [i.name for m in second for i in m.images] == ["reference", "iso_ne", "front"]
    # the next call carries only the newest render's three; the first render's message keeps
    # its text and says its two views were left out
    assert [i.name for m in third for i in m.images] == ["reference", "left", "top", "front"]
    first_render = next(m for m in third if m.role == "user" and m.text.startswith("rendered 2 view"))
    assert not first_render.images and "(2 earlier view(s) omitted" in first_render.text
    assert "Views, in order: iso_ne" in first_render.text  # its names and legend stay
    # later calls keep sending only the newest render, however long the conversation grows
    last = host.requests[3]
    assert sum(len(m.images) for m in last) == 1 + 3
