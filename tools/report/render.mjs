// Renders maptune's report data (written by `maptune report`) into OUT_DIR/index.html — one
// self-contained page with the Vega, Vega-Lite and vega-embed runtimes inlined, opening from
// file:// offline — and every figure as OUT_DIR/figures/*.svg for papers.
//
//   node tools/report/render.mjs REPORT_DATA.json OUT_DIR [--refresh SECONDS]
//
// --refresh makes the page reload itself (maptune report --follow keeps re-rendering it).
import { readFileSync, writeFileSync, mkdirSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import * as vega from 'vega';
import * as vl from 'vega-lite';

const here = dirname(fileURLToPath(import.meta.url));
const [dataFile, outDir, ...rest] = process.argv.slice(2);
if (!dataFile || !outDir) {
  console.error('usage: node render.mjs REPORT_DATA.json OUT_DIR [--refresh SECONDS]');
  process.exit(2);
}
const refreshAt = rest.indexOf('--refresh');
const refresh = refreshAt >= 0 ? Number(rest[refreshAt + 1]) : 0;
const data = JSON.parse(readFileSync(dataFile, 'utf8'));
const runs = data.runs || [];

const SCHEMA = 'https://vega.github.io/schema/vega-lite/v5.json';
const fmt = (v, d = 3) => (v === null || v === undefined || Number.isNaN(v) ? '–' : Number(v).toFixed(d));
const signed = (d) => (Math.abs(d) < 5e-4 ? '±0.000' : (d > 0 ? '+' : '−') + Math.abs(d).toFixed(3));
const esc = (s) => String(s ?? '').replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c]);
// A log axis spans exactly the parameter's bounds: rounded out to powers of ten ("nice") it drew
// r 0.1–2 m on 0.1–10, most of the panel beyond the box.
const scaleOf = (spec) => (spec && spec.log ? { type: 'log', domain: [spec.low, spec.high], nice: false } : { zero: false });
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const n = s.length;
  return n === 0 ? null : n % 2 ? s[(n - 1) / 2] : (s[n / 2 - 1] + s[n / 2]) / 2;
};
// Errors span millimetres to wrong matches metres off: a symmetric log axis shows both.
const ERR_SCALE = { e_t: { type: 'symlog', constant: 0.01 }, e_r_deg: { type: 'symlog', constant: 0.1 } };
// A black-box run (`maptune optimize`) scores any objective: its value has no [0, 1] range and
// no matches behind it.
const blackBox = (run) => !!run.objective;
const valueName = (run) => (blackBox(run) ? 'value' : 'p');
const valueScale = (run) => (blackBox(run) ? { zero: false } : { domain: [0, 1] });
const baselineP = (run) => {
  const e = run.evaluations.find((x) => x.evaluation === run.baseline);
  return e ? e.p : null;
};

// ---- figures ---------------------------------------------------------------------------

// p per evaluation: points (colour: origin), best so far, the baseline. Several runs
// (seeds): every run's best so far, their median and min-max band.
function historyFigure() {
  if (runs.length === 1) {
    const run = runs[0];
    // A failed black-box evaluation has no value (a matcher's failure scores p = 0).
    // Multi-fidelity: a proposal stopped on the subset shows the subset's estimate of p.
    const status = (e) => (e.failed ? 'failed' : (e.fidelity || 1) > 1 ? `subset 1/${e.fidelity}: estimate` : 'ok');
    const values = run.evaluations.map((e) => ({ ...e, status: status(e), p: e.failed && blackBox(run) ? null : e.p }));
    const layers = [
      {
        name: 'history_points',
        mark: { type: 'point', filled: true, size: 45 },
        encoding: {
          x: { field: 'evaluation', type: 'quantitative', title: 'evaluation', axis: { tickMinStep: 1, format: 'd' } },
          y: { field: 'p', type: 'quantitative', title: valueName(run), scale: valueScale(run) },
          color: { field: 'origin', type: 'nominal', title: 'origin' },
          shape: { field: 'status', type: 'nominal', title: 'status' },
          tooltip: [{ field: 'evaluation' }, { field: 'p', format: '.4f' }, { field: 'm' }, { field: 'origin' }, { field: 'status' }, { field: 'error' }],
        },
      },
      {
        name: 'history_best',
        mark: { type: 'line', interpolate: 'step-after', color: '#d62728', strokeWidth: 2 },
        encoding: { x: { field: 'evaluation', type: 'quantitative' }, y: { field: 'best_so_far', type: 'quantitative' } },
      },
    ];
    const b = baselineP(run);
    if (b !== null) {
      layers.push({
        name: 'history_baseline',
        data: { values: [{ p: b, label: 'baseline' }] },
        mark: { type: 'rule', strokeDash: [6, 4], color: 'black' },
        encoding: { y: { field: 'p', type: 'quantitative' }, tooltip: [{ field: 'label' }, { field: 'p', format: '.4f' }] },
      });
    }
    return {
      $schema: SCHEMA,
      title: { text: `${valueName(run)} per evaluation${blackBox(run) ? ` (${run.objective.minimize ? 'minimized' : 'maximized'})` : ''}`, subtitle: 'red: best so far; dashed: baseline (first start point)' },
      width: 640, height: 260, data: { values }, layer: layers,
    };
  }
  // Several runs: grouped by experiment (the seeds of one experiment share a band).
  const lines = [];
  const groups = new Map();  // experiment -> evaluation -> best-so-far values
  for (const run of runs) {
    const experiment = run.record?.experiment ?? run.name;
    if (!groups.has(experiment)) groups.set(experiment, new Map());
    const byIndex = groups.get(experiment);
    for (const e of run.evaluations) {
      if (e.best_so_far === null) continue;
      lines.push({ experiment, run: run.name, evaluation: e.evaluation, best_so_far: e.best_so_far });
      if (!byIndex.has(e.evaluation)) byIndex.set(e.evaluation, []);
      byIndex.get(e.evaluation).push(e.best_so_far);
    }
  }
  const band = [...groups.entries()].flatMap(([experiment, byIndex]) => [...byIndex.entries()].map(([evaluation, v]) => ({
    experiment, evaluation, min: Math.min(...v), max: Math.max(...v), median: median(v), runs: v.length,
  })));
  const baselines = [...groups.keys()].map((experiment) => {
    const b = runs.filter((r) => (r.record?.experiment ?? r.name) === experiment).map(baselineP).filter((x) => x !== null);
    return b.length ? { experiment, p: median(b) } : null;
  }).filter((x) => x);
  const x = { field: 'evaluation', type: 'quantitative', title: 'evaluation', axis: { tickMinStep: 1, format: 'd' } };
  const color = { field: 'experiment', type: 'nominal', title: 'experiment' };
  const layers = [
    {
      name: 'history_band', data: { values: band },
      mark: { type: 'area', opacity: 0.2, interpolate: 'step-after' },
      encoding: { x, y: { field: 'min', type: 'quantitative', title: `best ${valueName(runs[0])} so far`, scale: valueScale(runs[0]) },
                  y2: { field: 'max' }, color },
    },
    {
      name: 'history_runs', data: { values: lines },
      mark: { type: 'line', interpolate: 'step-after', strokeWidth: 1, opacity: 0.5 },
      encoding: { x, y: { field: 'best_so_far', type: 'quantitative' }, color, detail: { field: 'run', type: 'nominal' },
                  tooltip: [{ field: 'run' }, { field: 'evaluation' }, { field: 'best_so_far', format: '.4f' }] },
    },
    {
      name: 'history_median', data: { values: band },
      mark: { type: 'line', interpolate: 'step-after', strokeWidth: 2.5 },
      encoding: { x, y: { field: 'median', type: 'quantitative' }, color,
                  tooltip: [{ field: 'experiment' }, { field: 'evaluation' }, { field: 'runs' }, { field: 'median', format: '.4f' }, { field: 'min', format: '.4f' }, { field: 'max', format: '.4f' }] },
    },
  ];
  if (baselines.length) {
    layers.push({
      name: 'history_baseline', data: { values: baselines },
      mark: { type: 'rule', strokeDash: [6, 4] },
      encoding: { y: { field: 'p', type: 'quantitative' }, color, tooltip: [{ field: 'experiment' }, { field: 'p', format: '.4f' }] },
    });
  }
  return {
    $schema: SCHEMA,
    title: { text: `best p so far: ${runs.length} runs of ${groups.size} experiment${groups.size === 1 ? '' : 's'}`,
             subtitle: 'thick: median over an experiment\'s runs (seeds); band: min–max; thin: each run; dashed: baseline' },
    width: 640, height: 260, layer: layers,
  };
}

// The thesis's four-panel best-so-far figure: the share of eps and v in p, m, and the
// translation and rotation errors of the matched pairs, for the baseline and every new best.
function progressFigure(run) {
  if (blackBox(run)) return null;
  if (!run.steps.length) return null;
  const order = run.steps.map((s) => s.label);
  const shares = run.steps.flatMap((s) => [
    { label: s.label, part: 'ε share (1−w_v)·eps', value: s.eps_share, p: s.p },
    { label: s.label, part: 'υ share w_v·v', value: s.v_share, p: s.p },
  ]);
  const errors = run.steps.flatMap((s) => s.errors.map((e) => ({ label: s.label, ...e })));
  const x = { field: 'label', type: 'ordinal', sort: order, title: null };
  const panels = [
    {
      name: 'progress_p', data: { values: shares }, height: 130,
      mark: 'bar',
      encoding: { x, y: { field: 'value', type: 'quantitative', stack: 'zero', title: 'p', scale: { domain: [0, 1] } },
                  color: { field: 'part', type: 'nominal', title: null }, tooltip: [{ field: 'label' }, { field: 'part' }, { field: 'value', format: '.4f' }, { field: 'p', format: '.4f' }] },
    },
    {
      name: 'progress_m', data: { values: run.steps }, height: 90,
      mark: { type: 'bar', color: '#7f7f7f' },
      encoding: { x, y: { field: 'm', type: 'quantitative', title: 'm' } },
    },
  ];
  if (errors.length) {
    panels.push({
      name: 'progress_et', data: { values: errors }, height: 110,
      mark: { type: 'boxplot', extent: 'min-max', size: 14 },
      encoding: { x, y: { field: 'e_t', type: 'quantitative', title: 'e_t [m]', scale: ERR_SCALE.e_t } },
    });
    panels.push({
      name: 'progress_er', data: { values: errors }, height: 110,
      mark: { type: 'boxplot', extent: 'min-max', size: 14 },
      encoding: { x: { ...x, title: 'baseline and each new best (evaluation)' },
                  y: { field: 'e_r_deg', type: 'quantitative', title: 'e_r [deg]', scale: ERR_SCALE.e_r_deg } },
    });
  }
  return {
    $schema: SCHEMA,
    title: { text: 'best so far', subtitle: 'p split into its ε and υ parts, m, and the errors of the matched pairs' },
    vconcat: panels.map((p) => ({ width: Math.max(220, 48 * order.length), ...p })),
  };
}

// Per-pair errors of the baseline and of the best set: boxes over the matched pairs.
function errorsFigure(run) {
  if (blackBox(run)) return null;
  if (run.steps.length === 0) return null;
  const first = run.steps[0];
  const last = run.steps[run.steps.length - 1];
  const sets = first.label === 'baseline' && first !== last ? [['baseline', first], ['best', last]] : [['best', last]];
  const values = sets.flatMap(([set, s]) => s.errors.map((e) => ({ set, ...e })));
  if (!values.length) return null;
  const panel = (field, title) => ({
    width: 160, height: 220,
    layer: [
      { mark: { type: 'boxplot', extent: 1.5, size: 30, opacity: 0.5 },
        encoding: { x: { field: 'set', type: 'nominal', title: null, sort: ['baseline', 'best'] },
                    y: { field, type: 'quantitative', title, scale: ERR_SCALE[field] }, color: { field: 'set', type: 'nominal', legend: null } } },
      { name: `errors_${field}_points`, mark: { type: 'point', size: 16, opacity: 0.7 },
        encoding: { x: { field: 'set', type: 'nominal', sort: ['baseline', 'best'] }, xOffset: { field: 'jitter', type: 'quantitative' },
                    y: { field, type: 'quantitative' }, color: { field: 'set', type: 'nominal', legend: null } } },
    ],
  });
  return {
    $schema: SCHEMA,
    title: { text: 'errors of the matched pairs: baseline vs best', subtitle: `reference: ${run.record?.dataset?.reference ?? ''}` },
    data: { values },
    transform: [{ calculate: 'random()', as: 'jitter' }],
    hconcat: [panel('e_t', 'e_t [m]'), panel('e_r_deg', 'e_r [deg]')],
  };
}

// GP 1-D slices through the best: mean ± 2σ along each parameter, every observation.
function slicesFigure(run) {
  if (!run.model) return null;
  const specOf = Object.fromEntries(run.space.map((s) => [s.name, s]));
  const charts = run.model.slices.map((slice) => {
    const name = slice.parameter;
    const line = slice.points.map((p) => ({ ...p, lo: p.mean - 2 * p.std, hi: p.mean + 2 * p.std }));
    const obs = run.evaluations.filter((e) => !e.failed).map((e) => ({ x: e.params[name], p: e.p, evaluation: e.evaluation }));
    const xEnc = { field: 'x', type: 'quantitative', title: name, scale: scaleOf(specOf[name]) };
    return {
      width: 190, height: 130,
      layer: [
        { name: `slice_${name}_band`, data: { values: line }, mark: { type: 'area', opacity: 0.25, color: '#1f77b4' },
          encoding: { x: xEnc, y: { field: 'lo', type: 'quantitative', title: valueName(run) }, y2: { field: 'hi' } } },
        { name: `slice_${name}_mean`, data: { values: line }, mark: { type: 'line', color: '#1f77b4' },
          encoding: { x: xEnc, y: { field: 'mean', type: 'quantitative' } } },
        { name: `slice_${name}_observations`, data: { values: obs }, mark: { type: 'point', size: 14, color: 'black', opacity: 0.6 },
          encoding: { x: xEnc, y: { field: 'p', type: 'quantitative' }, tooltip: [{ field: 'evaluation' }, { field: 'x' }, { field: 'p', format: '.4f' }] } },
        { data: { values: [{ x: slice.at }] }, mark: { type: 'rule', color: '#d62728', strokeDash: [4, 3] },
          encoding: { x: { field: 'x', type: 'quantitative' } } },
      ],
    };
  });
  return {
    $schema: SCHEMA,
    title: { text: 'GP slices through the best', subtitle: 'posterior mean ± 2σ along one parameter, the others at the best; dots: all evaluations (projected); red: the best' },
    columns: 3, concat: charts,
  };
}

// The 2-D grid of the model for two parameters: mean, σ, acquisition, and the samples.
function gridFigure(run) {
  const g = run.model && run.model.grid;
  if (!g) return null;
  const label = { labelExpr: "format(datum.value, '.3~g')", labelOverlap: true };
  const heat = (field, title, scheme) => ({
    name: `grid_${field}`, width: 170, height: 170, title,
    mark: 'rect',
    encoding: {
      x: { field: 'x', type: 'ordinal', title: g.x, axis: label, sort: 'ascending' },
      y: { field: 'y', type: 'ordinal', title: g.y, axis: label, sort: 'descending' },
      color: { field, type: 'quantitative', title, scale: { scheme }, legend: { orient: 'bottom', gradientLength: 120 } },
      tooltip: [{ field: 'x' }, { field: 'y' }, { field, format: '.4f' }],
    },
  });
  const specOf = Object.fromEntries(run.space.map((s) => [s.name, s]));
  const samples = run.evaluations.filter((e) => !e.failed).map((e) => ({ x: e.params[g.x], y: e.params[g.y], p: e.p, evaluation: e.evaluation }));
  return {
    $schema: SCHEMA,
    title: { text: `GP on ${g.x} × ${g.y}`, subtitle: 'the other parameters at the best; acquisition: the run\'s own' },
    data: { values: g.cells },
    resolve: { scale: { color: 'independent' }, legend: { color: 'independent' } },
    hconcat: [
      heat('mean', 'mean', 'viridis'),
      heat('std', 'σ', 'magma'),
      heat('acquisition', run.model.acquisition, 'plasma'),
      { name: 'grid_samples', width: 170, height: 170, title: 'samples', data: { values: samples },
        mark: { type: 'point', filled: true, size: 30 },
        encoding: { x: { field: 'x', type: 'quantitative', title: g.x, scale: scaleOf(specOf[g.x]) },
                    y: { field: 'y', type: 'quantitative', title: g.y, scale: scaleOf(specOf[g.y]) },
                    color: { field: 'p', type: 'quantitative', scale: { scheme: 'viridis' }, legend: { orient: 'bottom', gradientLength: 120 } },
                    tooltip: [{ field: 'evaluation' }, { field: 'x' }, { field: 'y' }, { field: 'p', format: '.4f' }] } },
    ],
  };
}

// Parallel coordinates of every successful evaluation, coloured by p (axes normalized to
// each parameter's range, log ranges on a log scale).
function parallelFigure(run) {
  const names = run.space.map((s) => s.name);
  const norm = (s, v) => (s.log ? Math.log(v / s.low) / Math.log(s.high / s.low) : (v - s.low) / (s.high - s.low));
  const values = run.evaluations.filter((e) => !e.failed).flatMap((e) =>
    run.space.map((s) => ({ evaluation: e.evaluation, p: e.p, parameter: s.name, value: e.params[s.name], position: norm(s, e.params[s.name]) })));
  if (!values.length) return null;
  return {
    $schema: SCHEMA,
    title: { text: 'all evaluations', subtitle: 'each line one evaluation; axes from the lower to the upper bound of each parameter' },
    width: Math.max(360, 80 * names.length), height: 240,
    data: { values },
    layer: [
      { name: 'parallel_lines', mark: { type: 'line', opacity: 0.55, strokeWidth: 1.2 },
        encoding: { x: { field: 'parameter', type: 'nominal', sort: names, title: null, axis: { grid: true, domain: false } },
                    y: { field: 'position', type: 'quantitative', title: 'lower → upper bound', scale: { domain: [0, 1] } },
                    detail: { field: 'evaluation', type: 'nominal' },
                    color: { field: 'p', type: 'quantitative', scale: { scheme: 'viridis' } },
                    order: { field: 'p' },
                    tooltip: [{ field: 'evaluation' }, { field: 'parameter' }, { field: 'value' }, { field: 'p', format: '.4f' }] } },
    ],
  };
}

// Parameter importance: inverse ARD length scales of the refitted GP, normalized to sum 1.
function importanceFigure(run) {
  if (!run.model) return null;
  return {
    $schema: SCHEMA,
    title: { text: 'parameter importance', subtitle: '1 / ARD length scale of the GP (inputs scaled to [0, 1]), normalized' },
    width: 360, height: 22 * run.model.importance.length,
    data: { values: run.model.importance },
    mark: 'bar', name: 'importance_bars',
    encoding: {
      y: { field: 'parameter', type: 'nominal', sort: '-x', title: null },
      x: { field: 'importance', type: 'quantitative', title: 'share' },
      tooltip: [{ field: 'parameter' }, { field: 'length_scale', format: '.3g' }, { field: 'importance', format: '.3f' }],
    },
  };
}

// ---- tables ----------------------------------------------------------------------------

// ", 0.213 s per pair" from the raw submaps (within/over the run-time budget), when measured.
function pairTime(run, evaluation) {
  const e = run.evaluations.find((x) => x.evaluation === evaluation);
  if (!e || !e.pair_s) return '';
  const budget = run.measure?.max_pair_seconds;
  const note = budget ? (e.pair_s <= budget ? ` (budget ${budget} s)` : ` — over the ${budget} s budget`) : '';
  return `, ${fmt(e.pair_s, 3)} s per pair${note}`;
}

function metadataTable(run) {
  const r = run.record || {};
  const v = valueName(run);
  const rows = blackBox(run) ? [
    ['experiment', `${r.experiment ?? ''} (${r.experiment_file ?? ''})`],
    ['objective', `${r.objective?.direction ?? ''} \`${r.objective?.command ?? ''}\` (${r.objective?.parallel ?? 1} at once${r.objective?.timeout_s ? `, timeout ${r.objective.timeout_s} s` : ''})`],
  ] : [
    ['experiment', `${r.experiment ?? ''} (${r.experiment_file ?? ''})`],
    ['dataset', `${r.dataset?.name ?? ''} ${r.dataset?.id ?? ''} — ${r.dataset?.view ?? ''}/${r.dataset?.reference ?? ''} (${r.dataset?.dir ?? ''})`],
    ['measure', `e* ${run.measure.e_star}, m* ${fmt(run.measure.m_star, 1)} (${r.measure?.m_star_rule ?? ''}), w_v ${run.measure.w_v}${run.measure.max_pair_seconds ? `; run-time budget ${run.measure.max_pair_seconds} s per pair: p·(budget/t)² above it` : ''}`],
    ['matcher', `${r.matcher?.id ?? ''} ${r.matcher?.version ?? ''}`],
  ];
  rows.push(
    ['optimizer', `${r.optimizer?.acquisition ?? ''}, seed ${r.optimizer?.seed ?? ''}, optimizing ${(r.optimizer?.optimize ?? []).join(', ')}`],
    ['budget', `${r.budget?.evaluations ?? ''} evaluations${r.budget?.seconds ? `, ${r.budget.seconds} s` : ''}`],
    ['ran', `${r.started_utc ?? ''} → ${r.finished_utc ?? '(running)'}, ${r.wall_s ?? '?'} s, ${run.evaluations.length} evaluations, ${r.stop_reason ?? r.state ?? ''}`],
    ['best', run.best !== null ? `${v} ${fmt(run.evaluations.find((e) => e.evaluation === run.best)?.p, 4)} at evaluation ${run.best}${pairTime(run, run.best)}` : 'none'],
    ['baseline', run.baseline !== null ? `${v} ${fmt(baselineP(run), 4)} at evaluation ${run.baseline}${pairTime(run, run.baseline)}` : 'no start point evaluated'],
  );
  return `<table class="meta">${rows.map(([k, v]) => `<tr><th>${esc(k)}</th><td>${esc(v)}</td></tr>`).join('')}</table>`;
}

function validationTable(run) {
  if (!run.validation.length) return '<p class="note">No validation yet (an experiment with a <code>validate:</code> section, or <code>maptune validate --run-dir</code>).</p>';
  const head = ['set', 'target', 'view', 'pairs', 'm*', 'p', 'p − baseline', 'm', 'eps', 'e_t med [m]', 'e_r med [deg]', 's per pair'];
  const rows = run.validation.map((v) => {
    const d = v.delta_p_vs_baseline;
    const cls = d === null || d === undefined || v.set === 'baseline' || Math.abs(d) < 5e-4 ? '' : d > 0 ? 'up' : 'down';
    return `<tr><td>${esc(v.set)}</td><td>${esc(v.target)}</td><td>${esc(`${v.view}/${v.reference}`)}</td><td>${v.pairs}</td>` +
      `<td>${fmt(v.m_star, 1)}</td><td>${fmt(v.p)}</td><td class="${cls}">${v.set === 'baseline' || d === null ? '' : signed(d)}</td>` +
      `<td>${v.m}</td><td>${fmt(v.eps)}</td><td>${fmt(v.e_t_median_m)}</td><td>${fmt(v.e_r_median_deg, 2)}</td><td>${fmt(v.pair_s)}</td></tr>`;
  });
  return `<table class="validation"><tr>${head.map((h) => `<th>${esc(h)}</th>`).join('')}</tr>${rows.join('')}</table>`;
}

// Several runs (seeds): median and spread of the best training p and of every validation score.
function repeatsTable() {
  if (runs.length < 2) return '';
  const rows = new Map();
  const add = (key, value) => {
    if (value === undefined || value === null) return;
    if (!rows.has(key)) rows.set(key, []);
    rows.get(key).push(value);
  };
  for (const run of runs) {
    const experiment = run.record?.experiment ?? run.name;
    add(`${experiment}: best p (training view)`, run.evaluations.find((e) => e.evaluation === run.best)?.p);
    for (const v of run.validation) add(`${experiment}: ${v.set} on ${v.target}`, v.p);
  }
  const body = [...rows.entries()].map(([k, xs]) => `<tr><td>${esc(k)}</td><td>${xs.length}</td><td>${fmt(median(xs))}</td>` +
    `<td>${fmt(Math.min(...xs))}</td><td>${fmt(Math.max(...xs))}</td><td>${fmt(Math.max(...xs) - Math.min(...xs))}</td></tr>`);
  return `<h2>Over ${runs.length} runs</h2><table class="validation"><tr><th>score</th><th>runs</th><th>median</th><th>min</th><th>max</th><th>spread</th></tr>${body.join('')}</table>`;
}

// ---- output ----------------------------------------------------------------------------

const figures = [];  // {id, title, spec}
const add = (id, spec) => { if (spec) figures.push({ id, spec }); };
add('history', historyFigure());
runs.forEach((run, i) => {
  const k = runs.length > 1 ? `run${i + 1}-` : '';
  add(`${k}progress`, progressFigure(run));
  add(`${k}errors`, errorsFigure(run));
  add(`${k}slices`, slicesFigure(run));
  add(`${k}grid`, gridFigure(run));
  add(`${k}parallel`, parallelFigure(run));
  add(`${k}importance`, importanceFigure(run));
});

mkdirSync(join(outDir, 'figures'), { recursive: true });
for (const f of figures) {
  const view = new vega.View(vega.parse(vl.compile(f.spec).spec), { renderer: 'none' });
  writeFileSync(join(outDir, 'figures', `${f.id}.svg`), await view.toSVG());
  view.finalize();
}

const runtime = ['vega/build/vega.min.js', 'vega-lite/build/vega-lite.min.js', 'vega-embed/build/vega-embed.min.js']
  .map((m) => readFileSync(join(here, 'node_modules', m), 'utf8').replace(/<\/script/gi, '<\\/script'));
const figureDiv = (id) => {
  const f = figures.find((x) => x.id === id);
  return f ? `<figure><div class="fig" id="fig-${id}" data-figure="${id}"></div><figcaption><a href="figures/${id}.svg">${id}.svg</a></figcaption></figure>` : '';
};
// One experiment's name, or how many experiments a report of several shows.
const experimentNames = [...new Set(runs.map((r) => r.record?.experiment ?? r.name))];
const title = !runs.length ? 'maptune report'
  : experimentNames.length === 1 ? `maptune report — ${esc(experimentNames[0])}`
  : `maptune report — ${experimentNames.length} experiments`;
const sections = runs.map((run, i) => {
  const k = runs.length > 1 ? `run${i + 1}-` : '';
  const notes = (run.notes || []).map((n) => `<li>${esc(n)}</li>`).join('');
  const matcherParts = blackBox(run) ? '' : `<h3>Validation on held-out views</h3>${validationTable(run)}
<h3>Best so far</h3>${figureDiv(`${k}progress`)}${figureDiv(`${k}errors`)}`;
  return `<section class="run"><h2>${esc(run.name)}</h2>${metadataTable(run)}
${matcherParts}
<h3>The model</h3>${figureDiv(`${k}slices`)}${figureDiv(`${k}grid`)}${figureDiv(`${k}importance`)}
<h3>All evaluations</h3>${figureDiv(`${k}parallel`)}
${notes ? `<ul class="notes">${notes}</ul>` : ''}</section>`;
});
const specs = Object.fromEntries(figures.map((f) => [f.id, f.spec]));
const html = `<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
${refresh > 0 ? `<meta http-equiv="refresh" content="${refresh}">` : ''}
<title>${title}</title>
<style>
body { font-family: system-ui, sans-serif; margin: 24px auto; max-width: 1180px; color: #222; }
h1 { font-size: 1.5em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 4px; margin-top: 2em; }
table { border-collapse: collapse; margin: 8px 0 16px; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 3px 8px; text-align: left; }
table.validation td { text-align: right; } table.validation td:nth-child(-n+3) { text-align: left; }
td.up { color: #1a7f37; font-weight: 600; } td.down { color: #c62828; font-weight: 600; }
figure { margin: 12px 0 24px; } figcaption { font-size: 0.8em; color: #666; }
.note, .notes { color: #666; font-size: 0.9em; }
</style></head>
<body>
<h1>${title}</h1>
<p class="note">Generated ${new Date().toISOString().replace(/\.\d+Z$/, 'Z')} from ${runs.length} run director${runs.length === 1 ? 'y' : 'ies'}${refresh > 0 ? `; reloads every ${refresh} s while the run goes on` : ''}.</p>
${figureDiv('history')}
${repeatsTable()}
${sections.join('\n')}
${runtime.map((code) => `<script>${code}</script>`).join('\n')}
<script>
const specs = ${JSON.stringify(specs).replace(/</g, '\\u003c')};
const done = [];
for (const [id, spec] of Object.entries(specs)) {
  done.push(vegaEmbed('#fig-' + id, spec, { renderer: 'svg', actions: false })
    .then(() => document.getElementById('fig-' + id).setAttribute('data-rendered', 'yes'))
    .catch((e) => {
      const el = document.getElementById('fig-' + id);
      el.textContent = 'This figure could not be drawn: ' + e;
      el.setAttribute('data-rendered', 'failed');
    }));
}
Promise.all(done).then(() => document.body.setAttribute('data-figures-done', String(done.length)));
</script>
</body></html>
`;
writeFileSync(join(outDir, 'index.html'), html);
console.log(`report: ${join(outDir, 'index.html')} (${(html.length / 1e6).toFixed(2)} MB), ${figures.length} figures in ${join(outDir, 'figures')}`);
