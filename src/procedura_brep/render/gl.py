"""The GL back end: one headless moderngl context on EGL, three shading modes, one draw call.

Each view is drawn at :data:`SUPERSAMPLE` times the requested size into three targets (colour,
part id, view-space normal); :mod:`.compose` derives outlines from the id and normal targets and
box-filters down. A mode without outlines (``pbr``: the build's ``sheet.png``) needs neither
extra target: :meth:`Renderer.draw_finished` draws the colour alone and box-filters it on the
GPU, the same bytes for a quarter of the pixels read back (about 0.1 s of a 7-view sheet here).
Nothing here depends on a display; Mesa llvmpipe renders on the CPU.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..headless import ensure_headless
from .views import Camera

log = logging.getLogger(__name__)

Mode = Literal["parts", "clay", "pbr"]
MODE_CODES: dict[str, int] = {"parts": 0, "clay": 1, "pbr": 2}
SUPERSAMPLE: int = 2
"""Render at this factor of the output size, then box-filter (deterministic anti-aliasing)."""

_VERT = """
#version 330
uniform mat4 u_vp;
in vec3 in_pos; in vec3 in_nrm; in vec3 in_pcol; in vec3 in_base; in vec2 in_mr; in float in_id;
out vec3 v_pos; out vec3 v_nrm; out vec3 v_pcol; out vec3 v_base; out vec2 v_mr; flat out float v_id;
void main() {
    v_pos = in_pos; v_nrm = in_nrm; v_pcol = in_pcol; v_base = in_base; v_mr = in_mr; v_id = in_id;
    gl_Position = u_vp * vec4(in_pos, 1.0);
}
"""

_FRAG = """
#version 330
uniform int u_mode; uniform bool u_ortho;
uniform vec3 u_eye; uniform vec3 u_fwd; uniform vec3 u_right; uniform vec3 u_up;
in vec3 v_pos; in vec3 v_nrm; in vec3 v_pcol; in vec3 v_base; in vec2 v_mr; flat in float v_id;
layout(location = 0) out vec4 f_color;
layout(location = 1) out float f_id;
layout(location = 2) out vec4 f_nrm;  // N * 0.5 + 0.5 in RGBA8
const float PI = 3.14159265;
vec3 srgb(vec3 c) { return pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)); }
vec3 lin(vec3 c) { return pow(c, vec3(2.2)); }
// camera-relative rig: key upper-left-front, fill right, rim from behind-above
vec3 key_dir() { return normalize(-u_fwd * 0.8 - u_right * 0.55 + u_up * 0.75); }
vec3 fill_dir() { return normalize(-u_fwd * 0.6 + u_right * 0.8 + u_up * 0.1); }
vec3 rim_dir() { return normalize(u_fwd * 0.7 + u_up * 0.7 + u_right * 0.2); }
vec3 env(vec3 d) {  // studio sky: bright above, dark floor, soft horizon
    float t = clamp(d.z * 0.5 + 0.5, 0.0, 1.0);
    return mix(vec3(0.08, 0.08, 0.09), vec3(1.0, 1.0, 1.02), smoothstep(0.3, 0.8, t));
}
vec3 ggx(vec3 N, vec3 V, vec3 L, vec3 base, float metal, float rough) {
    vec3 H = normalize(V + L);
    float NL = max(dot(N, L), 0.0), NV = max(dot(N, V), 1e-4), NH = max(dot(N, H), 0.0);
    float a = max(rough * rough, 2e-3), a2 = a * a;
    float d = NH * NH * (a2 - 1.0) + 1.0;
    float D = a2 / (PI * d * d);
    float k = (rough + 1.0) * (rough + 1.0) / 8.0;
    float G = (NV / (NV * (1.0 - k) + k)) * (NL / (NL * (1.0 - k) + k));
    vec3 F0 = mix(vec3(0.04), base, metal);
    vec3 F = F0 + (1.0 - F0) * pow(1.0 - max(dot(H, V), 0.0), 5.0);
    vec3 spec = D * G * F / (4.0 * NV * max(NL, 1e-4));
    vec3 kd = (1.0 - F) * (1.0 - metal);
    return (kd * base / PI + spec) * NL;
}
void main() {
    vec3 N = normalize(v_nrm);
    if (!gl_FrontFacing) N = -N;
    vec3 V = u_ortho ? -u_fwd : normalize(u_eye - v_pos);
    if (dot(N, V) < 0.0) N = normalize(N - 1.01 * dot(N, V) * V);
    vec3 c;
    if (u_mode == 0) {
        vec3 L = normalize(-u_fwd + u_up * 0.6 - u_right * 0.4);
        c = v_pcol * (0.45 + 0.55 * max(dot(N, L), 0.0));
    } else if (u_mode == 1) {
        vec3 albedo = vec3(0.62);
        float hemi = 0.5 + 0.5 * N.z;
        vec3 light = vec3(0.85) * max(dot(N, key_dir()), 0.0) + vec3(0.25) * max(dot(N, fill_dir()), 0.0)
                   + vec3(0.3) * max(dot(N, rim_dir()), 0.0) + mix(vec3(0.06), vec3(0.16), hemi);
        c = srgb(albedo * light);
    } else {
        vec3 base = lin(v_base); float metal = v_mr.x; float rough = clamp(v_mr.y, 0.04, 1.0);
        vec3 col = ggx(N, V, key_dir(), base, metal, rough) * 3.2 * PI
                 + ggx(N, V, fill_dir(), base, metal, rough) * 1.0 * PI
                 + ggx(N, V, rim_dir(), base, metal, rough) * 1.6 * PI;
        vec3 F0 = mix(vec3(0.04), base, metal);
        vec3 R = reflect(-V, N);
        vec3 spec_env = mix(env(R), env(N) * 0.6 + 0.2, rough * rough);
        float NV = max(dot(N, V), 0.0);
        vec3 F = F0 + (max(vec3(1.0 - rough), F0) - F0) * pow(1.0 - NV, 5.0);
        col += F * spec_env * 0.9 + (1.0 - metal) * base * env(N) * 0.35;
        col = col / (col + vec3(0.9)) * 1.6;  // soft Reinhard shoulder
        c = srgb(col);
    }
    f_color = vec4(c, 1.0);
    f_id = v_id;
    f_nrm = vec4(N * 0.5 + 0.5, 1.0);
}
"""


_QUAD_VERT = """
#version 330
void main() {  // one triangle over the whole viewport, no vertex buffer
    vec2 p = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));
    gl_Position = vec4(p, 0.0, 1.0);
}
"""

# compose.finish for a line-free mode, on the GPU: each output pixel is the rounded mean of its
# s x s samples, a sample the background where nothing was drawn (alpha 0); integer arithmetic
# in floats (exact below 2**24), so the bytes are those of compose.finish
_BOX_FRAG = """
#version 330
uniform sampler2D u_src; uniform int u_s; uniform vec3 u_bg;
out vec4 f_color;
void main() {
    ivec2 at = ivec2(gl_FragCoord.xy) * u_s;
    vec3 total = vec3(0.0);
    for (int i = 0; i < u_s; ++i) {
        for (int j = 0; j < u_s; ++j) {
            vec4 c = texelFetch(u_src, at + ivec2(i, j), 0);
            total += c.a > 0.0 ? floor(c.rgb * 255.0 + 0.5) : u_bg;
        }
    }
    float n = float(u_s * u_s);
    f_color = vec4(floor((total + floor(n / 2.0)) / n) / 255.0, 1.0);
}
"""


@dataclass
class Frame:
    """One supersampled view: colour (H, W, 3) uint8, part id (H, W) int32 (0 = background;
    in ``pbr`` mode, which draws no outlines, 1 for any part), normals (H, W, 3) uint8 encoding
    N * 0.5 + 0.5 (parts mode only, else None)."""

    color: np.ndarray
    ids: np.ndarray
    normals: np.ndarray | None


class Renderer:
    """A headless moderngl context with the compiled shader program (create once per process)."""

    def __init__(self) -> None:
        ensure_headless()
        import moderngl  # lazy: ~50 ms, and only the render path needs GL

        self._mgl = moderngl
        self.ctx: Any = moderngl.create_context(standalone=True, backend="egl")
        self.prog = self.ctx.program(vertex_shader=_VERT, fragment_shader=_FRAG)
        self.box = self.ctx.program(vertex_shader=_QUAD_VERT, fragment_shader=_BOX_FRAG)
        self.info = dict(self.ctx.info)
        log.info("GL renderer: %s", self.info.get("GL_RENDERER"))

    def draw(self, vertices: np.ndarray, cameras: list[Camera], size: int, mode: Mode) -> list[Frame]:
        """Draw the interleaved ``vertices`` (see :func:`scene.vertex_array`) from each camera."""
        ss = size * SUPERSAMPLE
        out: list[Frame] = []
        with self.ctx:
            ctx = self.ctx
            color = ctx.renderbuffer((ss, ss), 4)
            ids = ctx.renderbuffer((ss, ss), 1, dtype="f4")
            nrm = ctx.renderbuffer((ss, ss), 4)
            depth = ctx.depth_renderbuffer((ss, ss))
            fbo = ctx.framebuffer(color_attachments=[color, ids, nrm], depth_attachment=depth)
            vbo, vao = self._scene(vertices)
            try:
                fbo.use()
                ctx.viewport = (0, 0, ss, ss)
                ctx.enable(self._mgl.DEPTH_TEST)
                ctx.disable(self._mgl.CULL_FACE)
                self.prog["u_mode"].value = MODE_CODES[mode]
                for cam in cameras:
                    fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
                    if vao is not None:
                        self._set_camera(cam)
                        vao.render()
                    c = np.frombuffer(fbo.read(components=4, attachment=0), np.uint8).reshape(ss, ss, 4)
                    if mode == "pbr":  # no outlines: only drawn or not matters, the colour's alpha
                        idmap = (c[::-1, :, 3] > 0).astype(np.int32)
                    else:
                        i = np.frombuffer(fbo.read(components=1, attachment=1, dtype="f4"), np.float32)
                        idmap = i.reshape(ss, ss)[::-1].astype(np.int32)
                    n = None
                    if mode == "parts":
                        n = np.frombuffer(fbo.read(components=4, attachment=2), np.uint8)
                        n = n.reshape(ss, ss, 4)[::-1, :, :3]
                    out.append(Frame(color=c[::-1, :, :3], ids=idmap, normals=n))
            finally:
                for obj in (vao, vbo, fbo, color, ids, nrm, depth):
                    if obj is not None:
                        obj.release()
        return out


    def draw_finished(self, vertices: np.ndarray, cameras: list[Camera], size: int, mode: Mode,
                      background: tuple[int, int, int]) -> list[np.ndarray]:
        """What :func:`.compose.finish` makes of :meth:`draw`'s frames, for a mode without
        outlines (``pbr``), made on the GPU: each view drawn supersampled into a colour texture
        only (no id or normal target), then box-filtered over ``background`` into an output of
        ``size``, which alone is read back. (size, size, 3) uint8 per camera, byte for byte
        :func:`.compose.finish` (tests/render/test_render.py compares them)."""
        ss = size * SUPERSAMPLE
        out: list[np.ndarray] = []
        with self.ctx:
            ctx = self.ctx
            color = ctx.texture((ss, ss), 4)
            depth = ctx.depth_renderbuffer((ss, ss))
            fbo = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
            small = ctx.renderbuffer((size, size), 4)
            down = ctx.framebuffer(color_attachments=[small])
            quad = ctx.vertex_array(self.box, [])
            vbo, vao = self._scene(vertices)
            try:
                self.prog["u_mode"].value = MODE_CODES[mode]
                self.box["u_s"].value = SUPERSAMPLE
                self.box["u_bg"].value = tuple(float(c) for c in background)
                for cam in cameras:
                    fbo.use()
                    ctx.viewport = (0, 0, ss, ss)
                    ctx.enable(self._mgl.DEPTH_TEST)
                    ctx.disable(self._mgl.CULL_FACE)
                    fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
                    if vao is not None:
                        self._set_camera(cam)
                        vao.render()
                    down.use()
                    ctx.viewport = (0, 0, size, size)
                    ctx.disable(self._mgl.DEPTH_TEST)
                    color.use(0)
                    quad.render(self._mgl.TRIANGLES, vertices=3)
                    c = np.frombuffer(down.read(components=3), np.uint8).reshape(size, size, 3)
                    out.append(c[::-1].copy())
            finally:
                for obj in (vao, vbo, quad, down, small, fbo, color, depth):
                    if obj is not None:
                        obj.release()
        return out

    def _scene(self, vertices: np.ndarray) -> tuple[Any, Any]:
        """The vertex buffer and array of the interleaved ``vertices`` (None, None when empty):
        the caller releases them."""
        if not len(vertices):
            return None, None
        vbo = self.ctx.buffer(vertices.tobytes())
        return vbo, self.ctx.vertex_array(self.prog, [(vbo, "3f 3f 3f 3f 2f 1f", "in_pos", "in_nrm",
                                                       "in_pcol", "in_base", "in_mr", "in_id")])

    def _set_camera(self, cam: Camera) -> None:
        self.prog["u_vp"].write(cam.view_proj.T.astype("f4").tobytes())
        self.prog["u_ortho"].value = bool(cam.ortho)
        for key, vec in (("u_eye", cam.eye), ("u_fwd", cam.forward),
                         ("u_right", cam.right), ("u_up", cam.up)):
            if key in self.prog:
                self.prog[key].value = tuple(float(x) for x in vec)


_LOCK = threading.Lock()
_RENDERER: Renderer | None = None


def renderer() -> Renderer:
    """The process-wide :class:`Renderer` (created on first use)."""
    global _RENDERER
    with _LOCK:
        if _RENDERER is None:
            _RENDERER = Renderer()
        return _RENDERER
