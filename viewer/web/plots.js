// Small line plots on a 2-D canvas (nodes against time, milliseconds per component), in the
// spirit of the paper's Fig. 7. No library: a few axes and polylines.

const PALETTE = ['#5fb3ff', '#ff7a33', '#7ddc6f', '#e36bd8', '#f2d64b', '#59e0c8', '#b48cff', '#ff5f7a'];

function niceMax(v) {
  if (!(v > 0)) return 1;
  const p = Math.pow(10, Math.floor(Math.log10(v)));
  for (const m of [1, 2, 2.5, 5, 10]) if (m * p >= v) return m * p;
  return 10 * p;
}

// series: [{label, x: [...], y: [...]}] (null y values are gaps). Draws on `canvas`.
export function drawPlot(canvas, series, xLabel, yLabel) {
  const ctx = canvas.getContext('2d');
  const w = canvas.width, h = canvas.height;
  const left = 46, right = 8, top = 8, bottom = 26;
  ctx.clearRect(0, 0, w, h);
  let xMin = Infinity, xMax = -Infinity, yMax = 0;
  for (const s of series) {
    for (let k = 0; k < s.x.length; ++k) {
      if (s.y[k] === null || s.y[k] === undefined) continue;
      xMin = Math.min(xMin, s.x[k]); xMax = Math.max(xMax, s.x[k]); yMax = Math.max(yMax, s.y[k]);
    }
  }
  ctx.strokeStyle = '#556'; ctx.fillStyle = '#99a'; ctx.font = '11px sans-serif';
  ctx.strokeRect(left, top, w - left - right, h - top - bottom);
  ctx.fillText(yLabel, 4, top + 10);
  ctx.fillText(xLabel, w - right - ctx.measureText(xLabel).width, h - 4);
  if (!isFinite(xMin)) { ctx.fillText('no data yet', left + 10, top + 30); return; }
  if (xMax <= xMin) xMax = xMin + 1;
  yMax = niceMax(yMax);
  ctx.fillText(String(yMax), 4, top + 24);
  ctx.fillText('0', 30, h - bottom);
  ctx.fillText(xMin.toFixed(2), left, h - 12);
  ctx.fillText(xMax.toFixed(2), w - right - 40, h - 12);
  const X = (x) => left + (x - xMin) / (xMax - xMin) * (w - left - right);
  const Y = (y) => h - bottom - y / yMax * (h - top - bottom);
  series.forEach((s, i) => {
    ctx.strokeStyle = PALETTE[i % PALETTE.length];
    ctx.beginPath();
    let pen = false;
    for (let k = 0; k < s.x.length; ++k) {
      const y = s.y[k];
      if (y === null || y === undefined) { pen = false; continue; }
      if (pen) ctx.lineTo(X(s.x[k]), Y(y)); else ctx.moveTo(X(s.x[k]), Y(y));
      pen = true;
    }
    ctx.stroke();
    if (series.length > 1) {
      ctx.fillStyle = PALETTE[i % PALETTE.length];
      ctx.fillText(s.label, left + 6 + (i % 4) * 95, top + 12 + Math.floor(i / 4) * 12);
    }
  });
}
