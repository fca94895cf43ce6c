"""The report's animated 3D view: a small canvas renderer (inline JavaScript, no library, no
network) of the scenes built by `legplan.report.scene`, embedded in the page as JSON.

Perspective projection of a camera orbiting the scene's centre (drag to orbit, wheel to zoom),
painter's order (terrain quads far to near, then support polygon, base box, the links' shape
faces far to near and the legs' skeleton lines, spheres far to near, CoM and force arrows), play/pause and a frame slider. Each viewer keeps its current frame in the
`data-frame` attribute of its element.
"""

from __future__ import annotations

import json
from html import escape

BACKGROUND = "#eef2f7"   # the canvas background; the report test looks for it in a screenshot

VIEWER_JS = """
(function () {
  "use strict";
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function unit(a) { var n = Math.sqrt(dot(a, a)) || 1; return [a[0] / n, a[1] / n, a[2] / n]; }
  function points(flat) { var out = []; for (var i = 0; i + 2 < flat.length; i += 3) out.push([flat[i] / 1000, flat[i + 1] / 1000, flat[i + 2] / 1000]); return out; }
  function rotate(q, v) {  // unit quaternion (x, y, z, w) applied to v
    var t = [2 * (q[1] * v[2] - q[2] * v[1]), 2 * (q[2] * v[0] - q[0] * v[2]), 2 * (q[0] * v[1] - q[1] * v[0])];
    return [v[0] + q[3] * t[0] + q[1] * t[2] - q[2] * t[1], v[1] + q[3] * t[1] + q[2] * t[0] - q[0] * t[2],
            v[2] + q[3] * t[2] + q[0] * t[1] - q[1] * t[0]];
  }
  function ramp(t) {  // low blue-grey to high sand
    t = Math.max(0, Math.min(1, t));
    return [90 + 130 * t, 110 + 90 * t, 140 + 20 * t];
  }

  function terrainQuads(t) {
    var quads = [], low = Infinity, high = -Infinity, i, j;
    if (!t) return quads;
    for (i = 0; i < t.z.length; i++) { low = Math.min(low, t.z[i]); high = Math.max(high, t.z[i]); }
    function at(i, j) { return [(t.x0 + j * t.step) / 1000, (t.y0 + i * t.step) / 1000, t.z[i * t.nx + j] / 1000]; }
    for (i = 0; i + 1 < t.ny; i++) for (j = 0; j + 1 < t.nx; j++) {
      var c = [at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)];
      var n = unit(cross(sub(c[1], c[0]), sub(c[3], c[0])));
      var shade = 0.55 + 0.45 * Math.max(0, dot(n, unit([0.4, 0.3, 1])));
      var rgb = ramp(((c[0][2] + c[2][2]) / 2 * 1000 - low) / Math.max(high - low, 1));
      quads.push({c: c, fill: "rgb(" + rgb.map(function (v) { return Math.round(v * shade); }).join(",") + ")"});
    }
    return quads;
  }

  function Viewer(root, scene) {
    var canvas = root.querySelector("canvas"), ctx = canvas.getContext("2d");
    var slider = root.querySelector("input"), button = root.querySelector("button"), label = root.querySelector("span");
    var quads = terrainQuads(scene.terrain), frames = scene.frames, frame = 0, playing = true, last = null;
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    function extend(p) { for (var k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); } }
    frames.forEach(function (f) { points(f.s).forEach(extend); points(f.b || []).forEach(extend); points(f.k || []).forEach(extend); });
    quads.forEach(function (q) { q.c.forEach(extend); });
    var centre = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    var camera = {yaw: -2.2, pitch: 0.55, dist: 1.6 * Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 0.2)};
    slider.max = frames.length - 1;

    var view = null;  // eye and camera axes, set at the start of each draw
    function look() {
      var cp = Math.cos(camera.pitch);
      var eye = [centre[0] + camera.dist * cp * Math.cos(camera.yaw), centre[1] + camera.dist * cp * Math.sin(camera.yaw),
                 centre[2] + camera.dist * Math.sin(camera.pitch)];
      var f = unit(sub(centre, eye)), r = unit(cross(f, [0, 0, 1]));
      view = {eye: eye, f: f, r: r, u: cross(r, f), focal: canvas.height * 1.3};
    }
    function project(p) {
      var d = sub(p, view.eye), depth = Math.max(dot(d, view.f), 1e-3);
      return [canvas.width / 2 + view.focal * dot(d, view.r) / depth,
              canvas.height / 2 - view.focal * dot(d, view.u) / depth, depth, view.focal / depth];
    }
    function path(list, close) {
      ctx.beginPath();
      list.forEach(function (p, k) { var s = project(p); if (k) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]); });
      if (close) ctx.closePath();
    }
    function drawLinks(f, links) {  // link shapes placed by the frame's "l", far to near, then the skeleton
      var place = f.l || [], faces = [], balls = [];
      links.shapes.forEach(function (shape) {
        var o = shape.k * 7;
        if (o + 6 >= place.length) return;
        var at = [place[o] / 1000, place[o + 1] / 1000, place[o + 2] / 1000];
        var q = [place[o + 3] / 1e4, place[o + 4] / 1e4, place[o + 5] / 1e4, place[o + 6] / 1e4];
        var v = points(shape.v).map(function (x) { var r = rotate(q, x); return [r[0] + at[0], r[1] + at[1], r[2] + at[2]]; });
        var fill = links.colours[shape.k];
        if (shape.r !== undefined) { balls.push({c: v[0], r: shape.r / 1000, fill: fill}); return; }
        shape.f.forEach(function (face) {
          var c = face.map(function (k) { return v[k]; });
          faces.push({c: c, fill: fill, d: c.reduce(function (s, p) { return s + project(p)[2]; }, 0) / c.length});
        });
      });
      faces.sort(function (a, b) { return b.d - a.d; }).forEach(function (e) {
        path(e.c, true); ctx.globalAlpha = 0.8; ctx.fillStyle = e.fill; ctx.fill(); ctx.globalAlpha = 1;
        ctx.strokeStyle = "rgba(0,0,0,0.35)"; ctx.lineWidth = 0.6; ctx.stroke();
      });
      balls.forEach(function (b) {
        var s = project(b.c); ctx.beginPath(); ctx.arc(s[0], s[1], Math.max(1.5, b.r * s[3]), 0, 2 * Math.PI);
        ctx.fillStyle = b.fill; ctx.fill();
      });
      var skeleton = points(f.k || []), start = 0;
      links.legs.forEach(function (n) {
        if (start + n <= skeleton.length) {
          path(skeleton.slice(start, start + n), false);
          ctx.strokeStyle = links.line; ctx.lineWidth = 3; ctx.lineJoin = "round"; ctx.stroke();
        }
        start += n;
      });
    }
    function draw() {
      var f = frames[frame];
      look();
      ctx.fillStyle = root.dataset.background;
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      quads.map(function (q) { return {q: q, d: q.c.reduce(function (s, p) { return s + project(p)[2]; }, 0)}; })
        .sort(function (a, b) { return b.d - a.d; })
        .forEach(function (e) { path(e.q.c, true); ctx.fillStyle = e.q.fill; ctx.fill(); });
      var polygon = points(f.p);
      if (polygon.length) {
        path(polygon, true); ctx.fillStyle = "rgba(0,110,255,0.25)"; ctx.fill();
        ctx.strokeStyle = "#0a58ca"; ctx.lineWidth = 1.5; ctx.stroke();
      }
      var box = points(f.b || []);
      if (box.length === 8) {
        [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]].forEach(function (face) {
          path(face.map(function (k) { return box[k]; }), true);
          ctx.fillStyle = "rgba(120,120,130,0.35)"; ctx.fill(); ctx.strokeStyle = "#333"; ctx.lineWidth = 1; ctx.stroke();
        });
      }
      if (scene.links) drawLinks(f, scene.links);
      points(f.s).map(function (p, k) { return {s: project(p), k: k}; })
        .sort(function (a, b) { return b.s[2] - a.s[2]; })
        .forEach(function (e) {
          ctx.beginPath(); ctx.arc(e.s[0], e.s[1], Math.max(1.5, scene.radii[e.k] / 1000 * e.s[3]), 0, 2 * Math.PI);
          ctx.fillStyle = scene.colours[e.k]; ctx.fill(); ctx.strokeStyle = "rgba(0,0,0,0.4)"; ctx.lineWidth = 0.7; ctx.stroke();
        });
      var com = points(f.c)[0];
      if (com) {
        var ground = polygon.length ? polygon.reduce(function (s, p) { return s + p[2]; }, 0) / polygon.length : com[2];
        ctx.setLineDash([4, 3]); path([com, [com[0], com[1], ground]], false);
        ctx.strokeStyle = "#c00"; ctx.lineWidth = 1.2; ctx.stroke(); ctx.setLineDash([]);
        var s = project(com); ctx.beginPath(); ctx.arc(s[0], s[1], 5, 0, 2 * Math.PI); ctx.fillStyle = "#d00"; ctx.fill();
      }
      var arrows = f.a || [];
      for (var i = 0; i + 5 < arrows.length; i += 6) {
        var a = project(points(arrows.slice(i, i + 3))[0]), b = project(points(arrows.slice(i + 3, i + 6))[0]);
        var ang = Math.atan2(b[1] - a[1], b[0] - a[0]);
        ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]);
        ctx.lineTo(b[0] - 8 * Math.cos(ang - 0.4), b[1] - 8 * Math.sin(ang - 0.4)); ctx.moveTo(b[0], b[1]);
        ctx.lineTo(b[0] - 8 * Math.cos(ang + 0.4), b[1] - 8 * Math.sin(ang + 0.4));
        ctx.strokeStyle = "#e6007e"; ctx.lineWidth = 2; ctx.stroke();
      }
      slider.value = frame; label.textContent = f.label; root.dataset.frame = frame;
    }
    function tick(now) {
      if (playing && last !== null) {
        var advance = Math.floor((now - last) / (1000 * scene.dt));
        if (advance > 0) { frame = (frame + advance) % frames.length; last += advance * 1000 * scene.dt; draw(); }
      } else { last = now; }
      window.requestAnimationFrame(tick);
    }
    button.addEventListener("click", function () { playing = !playing; last = null; button.textContent = playing ? "pause" : "play"; });
    slider.addEventListener("input", function () { frame = +slider.value; playing = false; button.textContent = "play"; draw(); });
    var drag = null;
    canvas.addEventListener("mousedown", function (e) { drag = [e.clientX, e.clientY]; });
    window.addEventListener("mouseup", function () { drag = null; });
    window.addEventListener("mousemove", function (e) {
      if (!drag) return;
      camera.yaw -= 0.01 * (e.clientX - drag[0]);
      camera.pitch = Math.max(-0.2, Math.min(1.5, camera.pitch + 0.01 * (e.clientY - drag[1])));
      drag = [e.clientX, e.clientY]; draw();
    });
    canvas.addEventListener("wheel", function (e) { e.preventDefault(); camera.dist *= Math.exp(0.001 * e.deltaY); draw(); });
    draw();
    window.requestAnimationFrame(tick);
  }
  document.querySelectorAll(".viewer").forEach(function (root) {
    Viewer(root, JSON.parse(document.getElementById(root.dataset.scene).textContent));
  });
})();
"""


def viewer_html(scenes: list[tuple[str, dict]]) -> str:
    """One `<div class="viewer">` per `(anchor, scene)` with its scene as embedded JSON, then the
    renderer script once; "" without scenes."""
    if not scenes:
        return ""
    blocks = []
    for anchor, scene in scenes:
        data = json.dumps(scene, separators=(",", ":")).replace("</", "<\\/")
        blocks.append(
            f'<div class="viewer" id="{anchor}-view" data-scene="{anchor}-scene" data-background="{BACKGROUND}">'
            f"<h3>{escape(scene['title'])}</h3>"
            f'<canvas width="900" height="520" style="background:{BACKGROUND}"></canvas>'
            '<div class="controls"><button type="button">pause</button>'
            '<input type="range" min="0" value="0" step="1"> <span></span></div>'
            f'<script type="application/json" id="{anchor}-scene">{data}</script></div>')
    return "".join(blocks) + f"<script>{VIEWER_JS}</script>"
