/* The lagdsl animation player: reads the record in #lagdsl-data (animation/page.py writes it)
   and draws one frame at a time on the canvas. Plain JavaScript, no library, no network.

   The record: times[k] for every frame k; draws[i] = {kind, points[k][j] = [x, y] or [x, y, z],
   radius[k] (a point's, when given)}; dimension (2 or 3); speed (model seconds per second of
   playback); style (animation/style.py). The picture is fitted once to everything drawn over
   the whole run, so it neither jumps nor rescales while playing; y (2-D) and z (3-D) point up.

   For tests and tools, window.lagdslPlayer offers setFrame(k), play(), pause(), setSpeed(x),
   setCamera(azimuth, elevation) in degrees, pixelOf(point) (canvas pixels), frame and drawnFrame;
   every drawing ends with the event "lagdsl:frame" on document, its detail {frame}, and playback
   stops (at the end, or by pause()) with "lagdsl:pause". */
(function () {
  "use strict";

  var data = JSON.parse(document.getElementById("lagdsl-data").textContent);
  data.draws.forEach(function (draw) {      // JSON has no NaN: a value that was not a number is null
    draw.points = draw.points.map(function (frame) {
      return frame.map(function (point) { return point.map(finite); });
    });
    if (draw.radius) { draw.radius = draw.radius.map(finite); }
  });
  var style = data.style;
  var times = data.times;
  var last = times.length - 1;
  var canvas = document.getElementById("lagdsl-canvas");
  var context = canvas.getContext("2d");
  var slider = document.getElementById("lagdsl-slider");
  var playButton = document.getElementById("lagdsl-play");
  var speedChoice = document.getElementById("lagdsl-speed");
  var timeLabel = document.getElementById("lagdsl-time");
  var degree = Math.PI / 180;

  var state = {
    frame: 0, drawnFrame: -1, playing: false, speed: data.speed,
    anchorTime: times[0], anchorWall: 0,
    azimuth: style.azimuth * degree, elevation: style.elevation * degree
  };
  var view = null;     // {scale, u0, v0, width, height, pixel, extent}, from fit()

  function finite(value) {
    return value === null ? NaN : value;
  }

  function eachPoint(visit) {
    data.draws.forEach(function (draw) {
      draw.points.forEach(function (frame, k) {
        frame.forEach(function (point) {
          if (point.every(Number.isFinite)) { visit(point, draw, k); }
        });
      });
    });
  }

  /* The box of every finite point at every frame, widened by `reach(draw, k, point)`. */
  function bounds(reach) {
    var low = [Infinity, Infinity, Infinity], high = [-Infinity, -Infinity, -Infinity];
    eachPoint(function (point, draw, k) {
      var r = reach(draw, k, point);
      for (var i = 0; i < point.length; i++) {
        low[i] = Math.min(low[i], point[i] - r);
        high[i] = Math.max(high[i], point[i] + r);
      }
    });
    return {low: low.slice(0, data.dimension), high: high.slice(0, data.dimension)};
  }

  /* How far a shape reaches around a point of it: a point's radius, a circle's radius around
     its centre (in 2-D, where circles are drawn). */
  function reachOf(draw, k, point) {
    var r = 0;
    if (draw.radius) { r = draw.radius[k]; }
    if (draw.kind === "circle" && point === draw.points[k][0]) { r = distance(point, draw.points[k][1]); }
    return Number.isFinite(r) ? r : 0;
  }

  function distance(a, b) {
    var sum = 0;
    for (var i = 0; i < a.length; i++) { sum += (a[i] - b[i]) * (a[i] - b[i]); }
    return Math.sqrt(sum);
  }

  /* The centre and extent (the diagonal of the box) of the points alone; the 2-D view fits the
     box widened by the radii. */
  var points = bounds(function () { return 0; });
  var box = bounds(reachOf);
  var centre = points.low.map(function (low, i) { return Number.isFinite(low) ? (low + points.high[i]) / 2 : 0; });
  var extent = Number.isFinite(points.low[0]) ? distance(points.low, points.high) : 0;
  if (!(extent > 0)) { extent = 1; }

  /* The screen-plane coordinates (u right, v up) of a model point, in model units. In 3-D an
     orthographic camera at the azimuth and elevation looks at the centre of everything drawn. */
  function project(point) {
    if (data.dimension === 2) { return [point[0], point[1]]; }
    var x = point[0] - centre[0], y = point[1] - centre[1], z = point[2] - centre[2];
    var ca = Math.cos(state.azimuth), sa = Math.sin(state.azimuth);
    var ce = Math.cos(state.elevation), se = Math.sin(state.elevation);
    return [-sa * x + ca * y, -se * (ca * x + sa * y) + ce * z];
  }

  function fit() {
    var ratio = window.devicePixelRatio || 1;
    var width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    var height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    canvas.width = width;
    canvas.height = height;
    var usable = 1 - 2 * style.margin;
    var spanU, spanV, u0, v0;
    if (data.dimension === 2) {
      spanU = Math.max(box.high[0] - box.low[0], 1e-12 * extent);
      spanV = Math.max(box.high[1] - box.low[1], 1e-12 * extent);
      u0 = Number.isFinite(box.low[0]) ? (box.low[0] + box.high[0]) / 2 : 0;
      v0 = Number.isFinite(box.low[1]) ? (box.low[1] + box.high[1]) / 2 : 0;
      if (!(spanU > 0 && spanV > 0)) { spanU = spanV = extent; }
    } else {
      spanU = spanV = extent;     // the bounding sphere's diameter: no rescaling while orbiting
      u0 = v0 = 0;
    }
    view = {
      scale: Math.min(usable * width / spanU, usable * height / spanV),
      u0: u0, v0: v0, width: width, height: height,
      pixel: width / style.reference_width      // style's pixel sizes at this canvas width
    };
  }

  function pixelOf(point) {
    var uv = project(point);
    return [view.width / 2 + view.scale * (uv[0] - view.u0), view.height / 2 - view.scale * (uv[1] - view.v0)];
  }

  function polyline(pixels, color, width) {
    context.strokeStyle = color;
    context.lineWidth = width * view.pixel;
    context.lineJoin = "round";
    context.lineCap = "round";
    context.beginPath();
    var open = false;
    pixels.forEach(function (p) {
      if (!(Number.isFinite(p[0]) && Number.isFinite(p[1]))) { open = false; return; }
      if (open) { context.lineTo(p[0], p[1]); } else { context.moveTo(p[0], p[1]); open = true; }
    });
    context.stroke();
  }

  /* A disc filled with `fill`, see-through with an edge of `stroke` (a circle), solid without (a point). */
  function disc(p, radius, fill, stroke) {
    context.beginPath();
    context.arc(p[0], p[1], radius, 0, 2 * Math.PI);
    context.fillStyle = fill;
    context.globalAlpha = stroke ? style.circle_fill_alpha : 1;
    context.fill();
    context.globalAlpha = 1;
    if (stroke) {
      context.strokeStyle = stroke;
      context.lineWidth = style.line_width * view.pixel;
      context.stroke();
    }
  }

  /* The zigzag between two pixels: straight ends, then 2 coils corners alternating across the
     axis at half the spring's width (style.spring_width of the picture's extent). */
  function zigzag(a, b) {
    var dx = b[0] - a[0], dy = b[1] - a[1], length = Math.sqrt(dx * dx + dy * dy);
    if (!(length > 0)) { return [a, b]; }
    var nx = -dy / length, ny = dx / length;
    var half = style.spring_width * extent * view.scale / 2;
    var corners = 2 * style.spring_coils, start = style.spring_ends, span = 1 - 2 * style.spring_ends;
    var pixels = [a, [a[0] + start * dx, a[1] + start * dy]];
    for (var i = 0; i < corners; i++) {
      var along = start + span * (i + 0.5) / corners, side = i % 2 === 0 ? half : -half;
      pixels.push([a[0] + along * dx + side * nx, a[1] + along * dy + side * ny]);
    }
    pixels.push([b[0] - start * dx, b[1] - start * dy], b);
    return pixels;
  }

  var painters = {
    line: function (draw, k) { polyline(draw.points[k].map(pixelOf), style.colors.line, style.line_width); },
    point: function (draw, k) {
      var radius = draw.radius ? draw.radius[k] * view.scale : style.point_radius * view.pixel;
      draw.points[k].forEach(function (point) { disc(pixelOf(point), radius, style.colors.point, null); });
    },
    trail: function (draw, k) {
      draw.points[k].forEach(function (_, j) {
        var pixels = [];
        for (var f = 0; f <= k; f++) { pixels.push(pixelOf(draw.points[f][j])); }
        polyline(pixels, style.colors.trail, style.trail_width);
      });
    },
    circle: function (draw, k) {
      var centre = pixelOf(draw.points[k][0]), mark = pixelOf(draw.points[k][1]);
      disc(centre, distance(draw.points[k][0], draw.points[k][1]) * view.scale, style.colors.circle,
           style.colors.circle);
      polyline([centre, mark], style.colors.circle, style.line_width);
    },
    spring: function (draw, k) {
      var ends = draw.points[k].map(pixelOf);
      for (var j = 1; j < ends.length; j++) {
        polyline(zigzag(ends[j - 1], ends[j]), style.colors.spring, style.line_width * 0.6);
      }
    },
    frame: function (draw, k) {
      var origin = pixelOf(draw.points[k][0]);
      for (var axis = 0; axis < 3; axis++) {
        polyline([origin, pixelOf(draw.points[k][axis + 1])], style.axis_colors[axis], style.line_width);
      }
    },
    box: function (draw, k) {
      var corners = draw.points[k].map(pixelOf);
      for (var c = 0; c < 8; c++) {
        [4, 2, 1].forEach(function (bit) {
          if (!(c & bit)) { polyline([corners[c], corners[c | bit]], style.colors.box, style.line_width); }
        });
      }
    }
  };

  /* In 3-D, the directions of x, y and z in the lower left corner, so that turning is legible. */
  function orientation() {
    if (data.dimension !== 3) { return; }
    var size = 28 * view.pixel, base = [16 * view.pixel + size, view.height - 16 * view.pixel - size];
    var names = ["x", "y", "z"];
    context.font = Math.round(12 * view.pixel) + "px sans-serif";
    for (var axis = 0; axis < 3; axis++) {
      var unit = [0, 0, 0];
      unit[axis] = 1;
      var uv = project([centre[0] + unit[0], centre[1] + unit[1], centre[2] + unit[2]]);
      var tip = [base[0] + size * uv[0], base[1] - size * uv[1]];
      polyline([base, tip], style.axis_colors[axis], 1.5);
      context.fillStyle = style.axis_colors[axis];
      context.fillText(names[axis], tip[0] + 2, tip[1] - 2);
    }
  }

  function formatTime(t) {
    return "t = " + Number(t.toPrecision(6)) + " s";
  }

  function draw(k) {
    context.fillStyle = style.background;
    context.fillRect(0, 0, view.width, view.height);
    data.draws.forEach(function (element) { painters[element.kind](element, k); });
    orientation();
    timeLabel.textContent = formatTime(times[k]);
    slider.value = String(k);
    state.drawnFrame = k;
    document.dispatchEvent(new CustomEvent("lagdsl:frame", {detail: {frame: k}}));
  }

  /* The last frame at or before model time t. */
  function frameAt(t) {
    var low = 0, high = last;
    if (t >= times[last]) { return last; }
    while (low < high) {
      var middle = Math.ceil((low + high) / 2);
      if (times[middle] <= t) { low = middle; } else { high = middle - 1; }
    }
    return low;
  }

  function setFrame(k) {
    state.frame = Math.max(0, Math.min(last, Math.round(k)));
    anchor();
    draw(state.frame);
  }

  function anchor() {
    state.anchorTime = times[state.frame];
    state.anchorWall = performance.now();
  }

  function play() {
    if (state.frame >= last) { state.frame = 0; }
    state.playing = true;
    playButton.textContent = "Pause";
    anchor();
    window.requestAnimationFrame(tick);
  }

  function pause() {
    state.playing = false;
    playButton.textContent = "Play";
    document.dispatchEvent(new CustomEvent("lagdsl:pause", {detail: {frame: state.frame}}));
  }

  function tick(now) {
    if (!state.playing) { return; }
    var t = state.anchorTime + state.speed * Math.max(0, now - state.anchorWall) / 1000;   // a frame may start before play()
    var k = frameAt(t);
    if (k !== state.drawnFrame) {
      state.frame = k;
      draw(k);
    }
    if (k >= last) { pause(); return; }
    window.requestAnimationFrame(tick);
  }

  function setSpeed(speed) {
    state.speed = speed;
    anchor();
  }

  function speedOptions() {
    var choices = [0.1, 0.25, 0.5, 1, 2, 5, 10];
    if (choices.indexOf(data.speed) < 0) { choices.push(data.speed); }
    choices.sort(function (a, b) { return a - b; });
    choices.forEach(function (speed) {
      var option = document.createElement("option");
      option.value = String(speed);
      option.textContent = "\u00d7" + speed + (speed === 1 ? " (real time)" : "");
      option.selected = speed === data.speed;
      speedChoice.appendChild(option);
    });
  }

  function orbit() {
    if (data.dimension !== 3) { return; }
    var dragging = null;
    canvas.addEventListener("pointerdown", function (event) {
      dragging = [event.clientX, event.clientY];
      canvas.setPointerCapture(event.pointerId);
    });
    canvas.addEventListener("pointermove", function (event) {
      if (!dragging) { return; }
      setCamera((state.azimuth - (event.clientX - dragging[0]) * 0.01) / degree,
                (state.elevation + (event.clientY - dragging[1]) * 0.01) / degree);
      dragging = [event.clientX, event.clientY];
    });
    canvas.addEventListener("pointerup", function () { dragging = null; });
  }

  function setCamera(azimuth, elevation) {
    state.azimuth = azimuth * degree;
    state.elevation = Math.max(-89, Math.min(89, elevation)) * degree;
    draw(state.frame);
  }

  slider.max = String(last);
  slider.addEventListener("input", function () { setFrame(Number(slider.value)); });
  playButton.addEventListener("click", function () { if (state.playing) { pause(); } else { play(); } });
  speedChoice.addEventListener("change", function () { setSpeed(Number(speedChoice.value)); });
  document.addEventListener("keydown", function (event) {
    if (event.target.closest(".controls")) { return; }     // the controls handle their own keys
    if (event.key === " ") { event.preventDefault(); playButton.click(); }
    if (event.key === "ArrowRight") { setFrame(state.frame + 1); }
    if (event.key === "ArrowLeft") { setFrame(state.frame - 1); }
  });
  window.addEventListener("resize", function () { fit(); draw(state.frame); });
  speedOptions();
  orbit();
  document.getElementById("lagdsl-hint").hidden = data.dimension !== 3;

  window.lagdslPlayer = {
    data: data, setFrame: setFrame, play: play, pause: pause, setSpeed: setSpeed, setCamera: setCamera,
    pixelOf: pixelOf,
    get frame() { return state.frame; },
    get drawnFrame() { return state.drawnFrame; },
    get playing() { return state.playing; }
  };
  fit();
  draw(0);
  if (last > 0) { play(); }
}());
