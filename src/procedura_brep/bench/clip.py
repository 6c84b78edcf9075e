"""The optional CLIP score: prompt-to-render alignment on the judge's grey-clay renders.

Computed only when local weights are configured: ``--clip-weights [ARCH@]PATH`` or the
environment variable ``PROCEDURA_BREP_CLIP_WEIGHTS`` (``ARCH`` an open_clip architecture name,
default ``ViT-B-32``; ``PATH`` a local checkpoint file). Without a setting the score is reported
as not computed (null), never 0. Nothing is ever downloaded.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from .cases import BenchError

ENV_CLIP = "PROCEDURA_BREP_CLIP_WEIGHTS"
DEFAULT_ARCH = "ViT-B-32"
CLIP_SCALE = 100.0
"""CLIPScore convention: 100 * max(cos(image, text), 0), averaged over the views."""


@dataclass(frozen=True)
class ClipSetting:
    """Where the CLIP weights are and which architecture they are."""

    arch: str
    path: Path
    source: str  # "--clip-weights" or the environment variable


def clip_setting(value: str | None = None) -> ClipSetting | None:
    """The CLIP setting in force (the option, else the environment), or None (not computed).

    Raises:
        BenchError: the setting names a path that does not exist or an empty architecture.
    """
    source = "--clip-weights"
    if not value:
        value, source = os.environ.get(ENV_CLIP, "").strip(), ENV_CLIP
    if not value:
        return None
    arch, sep, path = value.partition("@")
    if not sep:
        arch, path = DEFAULT_ARCH, value
    if not arch.strip():
        raise BenchError(f"{source} = {value!r}: the architecture before '@' is empty; "
                         f"write ARCH@PATH (e.g. {DEFAULT_ARCH}@/models/clip.pt) or just PATH")
    p = Path(path).expanduser()
    if not p.exists():
        raise BenchError(f"{source}: CLIP weights {p} do not exist; give a local checkpoint "
                         f"or unset it (the CLIP column is then reported as not computed)")
    return ClipSetting(arch.strip(), p, source)


class ClipScorer:
    """Scores images against a text with local open_clip weights (lazy import)."""

    def __init__(self, setting: ClipSetting) -> None:
        try:
            import open_clip  # type: ignore[import-not-found]  # optional, only for --clip
            import torch  # type: ignore[import-not-found]  # optional, only for --clip
        except ImportError:
            raise BenchError(f"{setting.source} is set but open_clip is not installed: pip install "
                             "open_clip_torch (or unset it: the CLIP column is then not computed)") from None
        self._torch = torch
        self.model, _, self.preprocess = open_clip.create_model_and_transforms(
            setting.arch, pretrained=str(setting.path))
        self.model.eval()
        self.tokenizer = open_clip.get_tokenizer(setting.arch)

    def score(self, prompt: str, images: list[Path]) -> float:
        """Mean CLIPScore of ``images`` against ``prompt``."""
        from PIL import Image
        torch = self._torch
        with torch.no_grad():
            pix = torch.stack([self.preprocess(Image.open(p).convert("RGB")) for p in images])
            img = self.model.encode_image(pix)
            txt = self.model.encode_text(self.tokenizer([prompt]))
            img = img / img.norm(dim=-1, keepdim=True)
            txt = txt / txt.norm(dim=-1, keepdim=True)
            cos = (img @ txt.T).squeeze(-1).clamp(min=0)
        return round(float(cos.mean()) * CLIP_SCALE, 4)
