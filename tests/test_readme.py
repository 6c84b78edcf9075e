"""The README's two fresh-machine commands and the CI script that runs the second one."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).parents[1]


def bash_blocks() -> list[str]:
    return re.findall(r"^```bash\n(.*?)\n```", (ROOT / "README.md").read_text(), flags=re.S | re.M)


def test_readme_starts_with_two_one_line_commands_in_a_venv():
    first, second = bash_blocks()[:2]
    for cmd in (first, second):
        assert "\n" not in cmd
        # Debian 12 refuses a bare `pip install` (externally managed) and has no `python`.
        assert "apt-get install -y python3-venv" in cmd
        assert cmd.index("python3 -m venv .venv") < cmd.index(". .venv/bin/activate") < cmd.index("pip install")
    assert first.endswith("procedura-brep generate --model replay:examples/tapes/robot_arm_staged.jsonl "
                          "-o out/robot_arm")
    tape = ROOT / "examples" / "tapes" / "robot_arm_staged.jsonl"
    assert "recorded through exchange, model played by an external coding agent" in \
        tape.read_text().split("\n", 1)[0].lower()
    assert "pip install -e '.[dev]'" in second and second.endswith("python -m pytest -q -p no:cacheprovider")


def test_ci_runs_the_readmes_second_command_in_a_new_venv():
    script = (ROOT / ".ci" / "run").read_text()
    assert "rm -rf .venv" in script
    awk = re.search(r"cmd=\$\((awk .*?) README\.md\)", script)
    assert awk, "the CI script no longer reads its command from the README"
    got = subprocess.run(["bash", "-c", f"{awk.group(1)} README.md"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    assert got == bash_blocks()[1]
