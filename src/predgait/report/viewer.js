// predgait 3D stick-figure viewer: a small canvas renderer, no library, works offline.
// Each element <div class="pg-viewer"> holds a <script type="application/json"> with
// {time: [..], bodies: [{name, color, lines: [[frame][point][x,y,z]]}],
//  arrows: [{name, color, origin: [frame][x,y,z], vector: [frame][x,y,z]}]} in the lab
// frame (m; X forward, Y left, Z up). Drag to turn the view, wheel to zoom, space to pause.
(function () {
  "use strict";
  function finite(v) { return v !== null && isFinite(v); }  // JSON null: a missing value
  function setup(root) {
    var data = JSON.parse(root.querySelector("script[type='application/json']").textContent);
    var canvas = root.querySelector("canvas");
    var ctx = canvas.getContext("2d");
    var slider = root.querySelector("input[type=range]");
    var button = root.querySelector("button");
    var label = root.querySelector(".pg-time");
    var n = data.time.length;
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    data.bodies.forEach(function (body) {
      body.lines.forEach(function (line) {
        line.forEach(function (frame) {
          frame.forEach(function (p) {
            for (var k = 0; k < 3; k++) {
              if (finite(p[k])) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); }
            }
          });
        });
      });
    });
    lo[2] = Math.min(lo[2], 0);
    var centre = [0, 1, 2].map(function (k) { return (lo[k] + hi[k]) / 2; });
    var size = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 0.5);
    var view = {yaw: -0.6, pitch: 0.25, zoom: 1.0};
    var frame = 0, playing = true, last = 0;
    var step = n > 1 ? (data.time[n - 1] - data.time[0]) / (n - 1) : 0.05;
    slider.max = String(n - 1);

    function project(p) {
      var x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
      var cy = Math.cos(view.yaw), sy = Math.sin(view.yaw);
      var u = x * sy + y * cy;          // screen right
      var d = x * cy - y * sy;          // depth
      var cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
      var v = z * cp - d * sp;          // screen up
      var s = view.zoom * 0.8 * Math.min(canvas.width, canvas.height) / size;
      return [canvas.width / 2 + s * u, canvas.height / 2 - s * v];
    }
    function polyline(points, color, width) {
      ctx.strokeStyle = color; ctx.lineWidth = width; ctx.beginPath();
      var started = false;
      points.forEach(function (p) {
        if (!finite(p[0]) || !finite(p[1]) || !finite(p[2])) { started = false; return; }
        var q = project(p);
        if (started) { ctx.lineTo(q[0], q[1]); } else { ctx.moveTo(q[0], q[1]); started = true; }
      });
      ctx.stroke();
    }
    function ground() {
      var g = 0.25, x0 = Math.floor((lo[0] - 0.3) / g) * g, x1 = hi[0] + 0.3;
      var y0 = Math.floor((lo[1] - 0.3) / g) * g, y1 = hi[1] + 0.3;
      for (var x = x0; x <= x1 + 1e-9; x += g) { polyline([[x, y0, 0], [x, y1, 0]], "#dde3e8", 1); }
      for (var y = y0; y <= y1 + 1e-9; y += g) { polyline([[x0, y, 0], [x1, y, 0]], "#dde3e8", 1); }
    }
    function draw() {
      ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, canvas.width, canvas.height);
      ground();
      data.bodies.forEach(function (body) {
        body.lines.forEach(function (line) { polyline(line[Math.min(frame, line.length - 1)], body.color, 3); });
      });
      (data.arrows || []).forEach(function (arrow) {
        var o = arrow.origin[frame], v = arrow.vector[frame];
        if (!o || !v || !finite(o[0]) || !finite(v[0])) { return; }
        var tip = [o[0] + v[0], o[1] + v[1], o[2] + v[2]];
        polyline([o, tip], arrow.color, 2);
        var a = project(tip); ctx.fillStyle = arrow.color;
        ctx.beginPath(); ctx.arc(a[0], a[1], 3, 0, 2 * Math.PI); ctx.fill();
      });
      ctx.fillStyle = "#333"; ctx.font = "12px sans-serif";
      var y = 16;
      data.bodies.concat(data.arrows || []).forEach(function (item) {
        ctx.fillStyle = item.color; ctx.fillRect(8, y - 9, 14, 4); ctx.fillStyle = "#333";
        ctx.fillText(item.name, 28, y - 4); y += 16;
      });
      slider.value = String(frame);
      label.textContent = "t = " + data.time[frame].toFixed(3) + " s";
    }
    function tick(now) {
      if (playing && now - last >= Math.max(step * 1000, 16)) {
        frame = (frame + 1) % n; last = now; draw();
      }
      window.requestAnimationFrame(tick);
    }
    var dragging = null;
    canvas.addEventListener("mousedown", function (e) { dragging = [e.clientX, e.clientY]; });
    window.addEventListener("mouseup", function () { dragging = null; });
    window.addEventListener("mousemove", function (e) {
      if (!dragging) { return; }
      view.yaw += (e.clientX - dragging[0]) * 0.01;
      view.pitch = Math.max(-1.5, Math.min(1.5, view.pitch + (e.clientY - dragging[1]) * 0.01));
      dragging = [e.clientX, e.clientY]; draw();
    });
    canvas.addEventListener("wheel", function (e) {
      e.preventDefault(); view.zoom *= e.deltaY < 0 ? 1.1 : 1 / 1.1; draw();
    }, {passive: false});
    slider.addEventListener("input", function () { frame = Number(slider.value); playing = false; button.textContent = "play"; draw(); });
    button.addEventListener("click", function () { playing = !playing; button.textContent = playing ? "pause" : "play"; });
    draw();
    var pixels = ctx.getImageData(0, 0, canvas.width, canvas.height).data, inked = 0;
    for (var i = 0; i < pixels.length; i += 4) { if (pixels[i] < 200 || pixels[i + 2] < 200) { inked++; } }
    root.setAttribute("data-inked-pixels", String(inked));
    window.requestAnimationFrame(tick);
  }
  document.querySelectorAll(".pg-viewer").forEach(setup);
})();
