// ndbg HTML report: draws the figures from the JSON data block with plotly.js (embedded
// above), and plays the plan. No network: everything the page needs is in the file.
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("ndbg-data").textContent);
  var CONFIG = {displaylogo: false, responsive: true};

  function decode(s, Type) {  // base64 little-endian typed array (the meshes)
    var bin = atob(s), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  // ---- the 3D view and the plan ----------------------------------------------------------
  var view = document.getElementById("ndbg-view");
  var parts = D.view.parts.map(function (p) {
    return {id: p.id, colour: p.colour, pale: p.pale, x: decode(p.x, Float32Array),
            y: decode(p.y, Float32Array), z: decode(p.z, Float32Array),
            i: decode(p.i, Int32Array), j: decode(p.j, Int32Array), k: decode(p.k, Int32Array)};
  });
  var traces = parts.map(function (p) {
    return {type: "mesh3d", name: p.id, x: p.x, y: p.y, z: p.z, i: p.i, j: p.j, k: p.k,
            color: p.colour, flatshading: true, hovertext: p.id, hoverinfo: "text",
            lighting: {ambient: 0.55, diffuse: 0.8, specular: 0.1, roughness: 0.8},
            showlegend: false};
  });
  Plotly.newPlot(view, traces, D.view.layout, CONFIG);

  var n = D.moves.length, shown = parts.map(function () { return [0, 0, 0]; });
  var slider = document.getElementById("ndbg-step");
  var label = document.getElementById("ndbg-step-label");
  var lastStep = -1;

  function offsetAt(t, k) {
    var a = Math.floor(t), f = t - a, b = Math.min(a + 1, n), A = D.offsets[a][k], B = D.offsets[b][k];
    return [A[0] + f * (B[0] - A[0]), A[1] + f * (B[1] - A[1]), A[2] + f * (B[2] - A[2])];
  }

  function shift(arr, d) {
    var out = new Float32Array(arr.length);
    for (var i = 0; i < arr.length; i++) out[i] = arr[i] + d;
    return out;
  }

  function highlight(step) {  // the moving parts of the step in progress keep their colour
    if (step === lastStep) return;
    lastStep = step;
    var movers = step > 0 ? D.moves[step - 1].parts : null;
    var colours = parts.map(function (p, k) {
      return movers === null || movers.indexOf(k) >= 0 ? p.colour : p.pale;
    });
    Plotly.restyle(view, {color: colours});
    label.textContent = step > 0 ? D.moves[step - 1].text : "assembled (step 0/" + n + ")";
    var items = document.querySelectorAll("#ndbg-moves li");
    for (var i = 0; i < items.length; i++) items[i].classList.toggle("current", i === step - 1);
  }

  function pose(t) {  // t in [0, n]: disassembly steps done (fractions while playing)
    var update = {x: [], y: [], z: []}, idx = [];
    parts.forEach(function (p, k) {
      var o = offsetAt(t, k), s = shown[k];
      if (o[0] === s[0] && o[1] === s[1] && o[2] === s[2]) return;
      shown[k] = o;
      update.x.push(shift(p.x, o[0])); update.y.push(shift(p.y, o[1]));
      update.z.push(shift(p.z, o[2])); idx.push(k);
    });
    if (idx.length) Plotly.restyle(view, update, idx);
    highlight(Math.min(n, Math.ceil(t - 1e-9)));
  }

  slider.addEventListener("input", function () { stop(); pose(Number(slider.value)); });
  document.querySelectorAll("#ndbg-moves li").forEach(function (li, i) {
    li.addEventListener("click", function () { stop(); slider.value = i + 1; pose(i + 1); });
  });

  // play: apart step by step, then back together; a step takes SECONDS_PER_STEP, and a
  // frame advances MAX_FRAME_STEP at most (where drawing is slow, it plays slower instead of
  // skipping steps)
  var SECONDS_PER_STEP = 0.9, MAX_FRAME_STEP = 0.25, playing = null;
  var button = document.getElementById("ndbg-play");
  function stop() { if (playing) { cancelAnimationFrame(playing.frame); playing = null; button.textContent = "Play"; } }
  button.addEventListener("click", function () {
    if (playing) { stop(); return; }
    if (!n) return;
    var last = null, u = Number(slider.value), total = 2 * n;  // u in 0..2n: apart, back
    playing = {frame: 0};
    button.textContent = "Pause";
    function frame(ts) {
      if (!playing) return;
      if (last !== null) u += Math.min((ts - last) / 1000 / SECONDS_PER_STEP, MAX_FRAME_STEP);
      last = ts;
      if (u >= total) { pose(0); slider.value = 0; stop(); return; }
      var t = u <= n ? u : total - u;
      pose(t);
      slider.value = Math.round(t);
      playing.frame = requestAnimationFrame(frame);
    }
    playing.frame = requestAnimationFrame(frame);
  });
  pose(0);

  // ---- the direction spheres -------------------------------------------------------------
  D.spheres.forEach(function (s) {
    var div = document.getElementById(s.div), panel = document.getElementById(s.div + "-dbg");
    Plotly.newPlot(div, s.traces, s.layout, CONFIG);
    div.on("plotly_hover", function (ev) {
      var t = ev.points[0].data;
      if (t.meta && t.meta.dbg !== undefined) panel.innerHTML = t.hovertext;
    });
  });
  document.body.setAttribute("data-ndbg-ready", "1");
})();
