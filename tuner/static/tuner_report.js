/* Interactive parts of tuner's report pages (run report, sweep report, runs dashboard).
 *
 * Loaded as a local file beside the page (the page's Content-Security-Policy allows scripts from its
 * own folder only). Reads its data from <script type="application/json" id="tuner-data">, never from
 * the network, and writes text with textContent only: names from runs (recordings, metrics,
 * parameters) are never parsed as HTML. Plot labels pass through esc(), because plotly renders a
 * subset of HTML tags in labels.
 */
(function () {
  'use strict';

  function esc(s) {
    return String(s).replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
  }

  function el(tag, attrs, text) {
    var e = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) { e.setAttribute(k, attrs[k]); });
    if (text !== undefined && text !== null) { e.textContent = String(text); }
    return e;
  }

  function fmt(v) {
    if (v === null || v === undefined || v === '') { return '-'; }
    if (typeof v === 'number') {
      if (!isFinite(v)) { return String(v); }
      if (Number.isInteger(v)) { return String(v); }
      return Number(v.toPrecision(4)).toString();
    }
    return String(v);
  }

  /* matplotlib's tab10: the colour of the i-th method, as in the PNGs (tuner.figures.method_color) */
  var COLORS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f',
                '#bcbd22', '#17becf'];

  var CONFIG = {responsive: true, displaylogo: false, modeBarButtonsToRemove: ['sendDataToCloud']};

  function baseLayout(extra) {
    var l = {margin: {l: 60, r: 20, t: 30, b: 50}, font: {size: 12}, hovermode: 'closest',
             legend: {orientation: 'h', y: -0.25}, autosize: true};
    Object.keys(extra || {}).forEach(function (k) { l[k] = extra[k]; });
    return l;
  }

  function plot(div, traces, layout) {
    return Plotly.newPlot(div, traces, layout, CONFIG).then(function () {
      div.setAttribute('data-rendered', '1');
    });
  }

  /* --- sortable tables ------------------------------------------------------------------------ */
  function cellValue(td) {
    var s = (td ? td.textContent : '').trim();
    var m = s.replace(/,/g, '').match(/^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?%?$/);
    if (m) { return {num: parseFloat(s.replace(/,/g, '')), text: s}; }
    return {num: null, text: s};
  }

  function sortTable(table, col, th) {
    var body = table.tBodies[0];
    if (!body) { return; }
    var asc = th.getAttribute('aria-sort') !== 'ascending';
    [].forEach.call(table.querySelectorAll('th'), function (h) { h.removeAttribute('aria-sort'); });
    th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
    var rows = [].slice.call(body.rows);
    rows.forEach(function (r, i) { r.__i = i; });
    rows.sort(function (a, b) {
      var x = cellValue(a.cells[col]), y = cellValue(b.cells[col]);
      var c;
      if (x.num !== null && y.num !== null) { c = x.num - y.num; }
      else if (x.num !== null) { c = -1; }           /* numbers before text ('-', 'nan') */
      else if (y.num !== null) { c = 1; }
      else { c = x.text.localeCompare(y.text); }
      if (c === 0) { return a.__i - b.__i; }
      return asc ? c : -c;
    });
    rows.forEach(function (r) { body.appendChild(r); });
  }

  function makeSortable(root) {
    [].forEach.call((root || document).querySelectorAll('table'), function (table) {
      if (table.getAttribute('data-sortable') === '1' || !table.tHead) { return; }
      table.setAttribute('data-sortable', '1');
      [].forEach.call(table.tHead.rows[0].cells, function (th, col) {
        th.classList.add('sortable');
        th.setAttribute('title', 'sort by this column');
        th.addEventListener('click', function () { sortTable(table, col, th); });
      });
    });
  }

  /* --- the report's plots: PLOTS[NAME](div, slot), slot = the page data's NAME entry, the data the PNG of
     the same plot is drawn from (tuner/plots/NAME.py) ------------------------------------------------------ */
  function convergence(div, c) {
    var tr = [{x: c.n_evals, y: c.best, name: 'best so far', mode: 'lines', line: {width: 2}},
              {x: c.n_evals, y: c.gen_median, name: 'generation median', mode: 'lines', opacity: 0.7}];
    if (c.runs) {  /* a sweep, or runs compared on the dashboard: one line per run */
      tr = c.runs.map(function (r) { return {x: r.x, y: r.y, name: esc(r.name), mode: 'lines'}; });
    }
    var shapes = (c.stage_starts || []).map(function (x) {  /* where a refinement stage starts */
      return {type: 'line', xref: 'x', yref: 'paper', x0: x, x1: x, y0: 0, y1: 1,
              line: {color: '#999', dash: 'dot', width: 1}};
    });
    return plot(div, tr, baseLayout({xaxis: {title: {text: 'evaluations'}}, shapes: shapes,
                                     yaxis: {title: {text: 'fitness'}, type: c.log ? 'log' : 'linear'},
                                     height: 360}));
  }

  function paramAxis(p) {
    var ax = {title: {text: esc(p.name + (p.unit ? ' (' + p.unit + ')' : ''))}};
    if (p.scale === 'log') { ax.type = 'log'; }
    return ax;
  }

  function slices(div, d) {
    var ps = d.params, pts = d.points;
    var jobs = ps.map(function (p) {
      var box = el('div', {'class': 'slice'});
      div.appendChild(box);
      var tr = [{x: pts.values[p.name], y: pts.fitness, mode: 'markers', name: 'evaluation',
                 marker: {size: 6, color: pts.eval, colorscale: 'Viridis', opacity: 0.75,
                          colorbar: ps.length === 1 ? {title: {text: 'eval'}} : undefined},
                 hovertemplate: esc(p.name) + ' = %{x:.4g}<br>fitness %{y:.4g}<extra></extra>'}];
      if (d.best && d.best[p.name] !== undefined) {
        tr.push({x: [d.best[p.name]], y: [d.best_fitness], mode: 'markers', name: 'best',
                 marker: {size: 13, symbol: 'star', color: '#d62728'}});
      }
      var lay = baseLayout({xaxis: paramAxis(p), yaxis: {title: {text: 'fitness'},
                            type: d.log ? 'log' : 'linear'}, showlegend: false, height: 300,
                            shapes: [p.low, p.high].map(function (v) {
                              return {type: 'line', xref: 'x', yref: 'paper', x0: v, x1: v, y0: 0, y1: 1,
                                      line: {color: '#999', dash: 'dot', width: 1}};
                            })});
      return Plotly.newPlot(box, tr, lay, CONFIG);
    });
    return Promise.all(jobs).then(function () { div.setAttribute('data-rendered', '1'); });
  }

  function parcoords(div, pc) {
    /* SVG lines (no WebGL): one line per candidate over the parameters' positions in their bounds,
       coloured in five bands by fitness rank, best band drawn last and darkest, the best in red */
    var names = pc.names, n = pc.u.length, bands = 5, tr = [];
    var colors = ['#d9d9d9', '#b4c7e7', '#7fa6d6', '#3f73b8', '#08306b'];
    for (var b = 0; b < bands; b++) {
      var xs = [], ys = [], txt = [];
      for (var i = 0; i < n; i++) {
        if (pc.band[i] !== b) { continue; }
        for (var j = 0; j < names.length; j++) {
          xs.push(j); ys.push(pc.u[i][j]);
          txt.push(esc(names[j]) + ' = ' + fmt(pc.values[i][j]) + '<br>fitness ' + fmt(pc.fitness[i]));
        }
        xs.push(null); ys.push(null); txt.push('');
      }
      if (!xs.length) { continue; }
      tr.push({x: xs, y: ys, text: txt, hoverinfo: 'text', mode: 'lines+markers', name: pc.band_labels[b],
               line: {color: colors[b], width: b === bands - 1 ? 2 : 1}, marker: {size: 4, color: colors[b]}});
    }
    tr.push({x: names.map(function (_, j) { return j; }), y: pc.u[0], mode: 'lines+markers',
             name: 'best (fitness ' + fmt(pc.fitness[0]) + ')', hoverinfo: 'text',
             text: names.map(function (nm, j) { return esc(nm) + ' = ' + fmt(pc.values[0][j]); }),
             line: {color: '#d62728', width: 2.5}, marker: {size: 7, color: '#d62728'}});
    return plot(div, tr, baseLayout({height: 380,
      xaxis: {tickmode: 'array', tickvals: names.map(function (_, j) { return j; }),
              ticktext: names.map(esc), range: [-0.2, names.length - 0.8]},
      yaxis: {title: {text: 'position in bounds (0 = low, 1 = high)'}, range: [-0.03, 1.03]}}));
  }

  function importance(div, im) {
    return plot(div, [{type: 'bar', orientation: 'h', x: im.share.slice().reverse(),
                       y: im.names.slice().reverse().map(esc),
                       hovertemplate: '%{y}: %{x:.1%}<extra></extra>'}],
                baseLayout({height: 105 + 30 * im.names.length, xaxis: {title: {text: 'share of explained variance'},
                            tickformat: '.0%', range: [0, 1]}, margin: {l: 120, r: 20, t: 35, b: 50}}));
  }

  function contour(div, c) {
    var tr = [{type: 'contour', x: c.gx, y: c.gy, z: c.z, colorscale: 'Viridis', reversescale: true,
               connectgaps: false, contours: {coloring: 'heatmap'},
               colorbar: {title: {text: c.log ? 'log10 fitness' : 'fitness'}}, hoverongaps: false},
              {x: c.px, y: c.py, mode: 'markers', name: 'evaluations', marker: {size: 5, color: '#222'},
               hoverinfo: 'x+y'},
              {x: [c.bx], y: [c.by], mode: 'markers', name: 'best', marker: {size: 14, symbol: 'star',
               color: '#d62728'}}];
    return plot(div, tr, baseLayout({height: 420, showlegend: false, xaxis: paramAxis(c.xp), yaxis: paramAxis(c.yp)}));
  }

  function timeseries(div, ts) {
    var items = ts.items;
    var bar = el('div', {'class': 'controls'});
    var lab = el('label', {}, (ts.select_label || 'recording') + ': ');
    var sel = el('select', {'aria-label': ts.select_label || 'recording'});
    items.forEach(function (it, i) { sel.appendChild(el('option', {value: String(i)}, it.label || it.name)); });
    lab.appendChild(sel);
    bar.appendChild(lab);
    var box = el('div', {'class': 'ts-plot'});
    div.appendChild(bar);
    div.appendChild(box);
    function draw(i) {
      var it = items[i], np = it.panels.length, gap = 0.06, h = (1 - gap * (np - 1)) / np, tr = [], seen = {};
      var lay = baseLayout({height: 170 * np + 90, showlegend: true, legend: {orientation: 'h', y: 1.08, x: 0},
                            margin: {l: 60, r: 20, t: 40, b: 45}});
      it.panels.forEach(function (p, k) {
        var ax = k === 0 ? '' : String(k + 1);
        var top = 1 - k * (h + gap);
        lay['yaxis' + ax] = {domain: [top - h, top], title: {text: esc(p.title + (p.unit ? ' (' + p.unit + ')' : '')),
                             font: {size: 11}}};
        lay['xaxis' + ax] = {anchor: 'y' + ax, matches: k === 0 ? undefined : 'x', showticklabels: k === np - 1,
                             title: k === np - 1 ? {text: esc(ts.x_label || 'time (s)')} : undefined};
        p.series.forEach(function (s) {
          tr.push({x: it.x, y: s.y, name: esc(s.name), mode: 'lines', xaxis: 'x' + ax, yaxis: 'y' + ax,
                   legendgroup: esc(s.name), showlegend: !seen[s.name],
                   line: {width: 1.2, dash: s.dash ? 'dot' : 'solid', color: s.color || undefined}});
          seen[s.name] = true;
        });
      });
      return Plotly.react(box, tr, lay, CONFIG);
    }
    sel.addEventListener('change', function () { draw(Number(sel.value)); });
    return draw(0).then(function () { div.setAttribute('data-rendered', '1'); });
  }

  function swept(div, d) {  /* a sweep's score against a swept grid value: every job, the medians joined */
    var tr = [];
    d.series.forEach(function (s, i) {
      var color = COLORS[i % COLORS.length];
      tr.push({x: s.x, y: s.y, mode: 'markers', name: esc(s.name), legendgroup: String(i), showlegend: false,
               marker: {size: 7, color: color, line: {width: 0.5, color: '#222'}},
               hovertemplate: esc(d.key) + ' = %{x}<br>%{y:.6g}<extra>' + esc(s.name) + '</extra>'});
      tr.push({x: s.mx, y: s.my, mode: 'lines', name: esc(s.name), legendgroup: String(i), line: {color: color}});
    });
    return plot(div, tr, baseLayout({height: 380, showlegend: d.series.length > 1,
                                     xaxis: {title: {text: esc(d.key)}},
                                     yaxis: {title: {text: esc(d.score.replace(/_/g, ' '))}}}));
  }

  var PLOTS = {convergence: convergence, slices: slices, parcoords: parcoords, importance: importance,
               contour: contour, traces: timeseries, swept: swept};

  /* --- runs dashboard ------------------------------------------------------------------------- */
  var COLS = [['name', 'name'], ['kind', 'kind'], ['objective', 'objective'], ['target', 'filter / controller'],
              ['status', 'status'], ['best', 'best'], ['cv', 'CV score'], ['gap', 'CV gap'],
              ['n_evals', 'evaluations'], ['wall_s', 'wall time (s)'], ['date', 'date']];

  function store(key, value) {
    try {
      if (value === undefined) { return JSON.parse(window.sessionStorage.getItem(key) || 'null'); }
      window.sessionStorage.setItem(key, JSON.stringify(value));
    } catch (e) { /* storage off (private mode): state is not kept across reloads */ }
    return null;
  }

  function dashboard(div, d) {
    var runs = d.runs, picked = store('tuner-dash-picked') || [], filt = store('tuner-dash-filter') || '';
    var m = /^#compare=(.*)$/.exec(window.location.hash);  /* a shareable selection: index.html#compare=a,b */
    if (m) { picked = decodeURIComponent(m[1]).split(','); }
    var controls = el('div', {'class': 'controls'});
    var lab = el('label', {}, 'filter: ');
    var input = el('input', {type: 'search', placeholder: 'name, filter, status ...', 'aria-label': 'filter runs'});
    input.value = filt;
    lab.appendChild(input);
    controls.appendChild(lab);
    var count = el('span', {'class': 'muted'});
    controls.appendChild(count);
    div.appendChild(controls);
    var wrap = el('div', {'class': 'table-scroll'});
    var table = el('table', {id: 'runs-table'});
    var head = el('tr');
    head.appendChild(el('th', {}, 'compare'));
    var TEXT = ['name', 'kind', 'objective', 'target', 'status', 'date'];
    COLS.forEach(function (c) { head.appendChild(el('th', TEXT.indexOf(c[0]) >= 0 ? {'class': 'txt'} : {}, c[1])); });
    var thead = el('thead');
    thead.appendChild(head);
    table.appendChild(thead);
    var body = el('tbody');
    runs.forEach(function (r, i) {
      var tr = el('tr', {'data-i': String(i)});
      var td = el('td');
      var cb = el('input', {type: 'checkbox', 'aria-label': 'compare ' + r.name});
      cb.checked = picked.indexOf(r.id) >= 0;
      cb.addEventListener('change', function () {
        picked = runs.filter(function (x, k) {
          var c = body.querySelector('tr[data-i="' + k + '"] input');
          return c && c.checked;
        }).map(function (x) { return x.id; });
        store('tuner-dash-picked', picked);
        compare();
      });
      td.appendChild(cb);
      tr.appendChild(td);
      COLS.forEach(function (c) {
        var cell = el('td');
        if (c[0] === 'name' && r.href) {
          cell.appendChild(el('a', {href: r.href}, r.name));
        } else {
          cell.textContent = fmt(r[c[0]]);
        }
        if (typeof r[c[0]] !== 'number') { cell.className = c[0] === 'name' ? 'txt name' : 'txt'; }
        if (c[0] === 'date') { cell.textContent = String(r.date || '-').replace('T', ' ').slice(0, 16); }
        tr.appendChild(cell);
      });
      body.appendChild(tr);
    });
    table.appendChild(body);
    wrap.appendChild(table);
    div.appendChild(wrap);
    makeSortable(div);
    function applyFilter() {
      var q = input.value.trim().toLowerCase(), shown = 0;
      store('tuner-dash-filter', input.value);
      [].forEach.call(body.rows, function (tr) {
        var hit = !q || tr.textContent.toLowerCase().indexOf(q) >= 0;
        tr.style.display = hit ? '' : 'none';
        shown += hit ? 1 : 0;
      });
      count.textContent = ' ' + shown + ' of ' + runs.length + ' shown';
    }
    input.addEventListener('input', applyFilter);
    applyFilter();
    var cmp = el('div', {id: 'compare'});
    div.appendChild(cmp);
    function sideBySide(title, key, sel) {
      var names = [];
      sel.forEach(function (r) { Object.keys(r[key] || {}).forEach(function (k) { if (names.indexOf(k) < 0) { names.push(k); } }); });
      if (!names.length) { return; }
      cmp.appendChild(el('h3', {}, title));
      var w = el('div', {'class': 'table-scroll'}), t = el('table'), th = el('thead'), hr = el('tr');
      hr.appendChild(el('th', {}, key === 'params' ? 'parameter' : 'metric'));
      sel.forEach(function (r) { hr.appendChild(el('th', {}, r.name)); });
      th.appendChild(hr);
      t.appendChild(th);
      var tb = el('tbody');
      names.forEach(function (n) {
        var row = el('tr');
        row.appendChild(el('td', {}, n));
        sel.forEach(function (r) {
          var v = (r[key] || {})[n];
          row.appendChild(el('td', typeof v === 'number' ? {} : {'class': 'txt'}, fmt(v)));
        });
        tb.appendChild(row);
      });
      t.appendChild(tb);
      w.appendChild(t);
      cmp.appendChild(w);
      makeSortable(w);
    }
    function compare() {
      cmp.textContent = '';
      var sel = runs.filter(function (r) { return picked.indexOf(r.id) >= 0; });
      if (!sel.length) {
        cmp.appendChild(el('p', {'class': 'muted'}, 'Tick runs in the first column to compare them side by side.'));
        return Promise.resolve();
      }
      cmp.appendChild(el('h2', {}, 'Selected runs side by side'));
      sideBySide('Parameters', 'params', sel);
      sideBySide('Metrics', 'metrics', sel);
      cmp.appendChild(el('h3', {}, 'Convergence'));
      var box = el('div', {'class': 'tuner-plot', 'data-plot': 'compare-convergence'});
      cmp.appendChild(box);
      var conv = {runs: sel.filter(function (r) { return r.conv; }).map(function (r) {
        return {name: r.name, x: r.conv.x, y: r.conv.y}; }), log: d.log};
      return convergence(box, conv);
    }
    compare();
    div.setAttribute('data-rendered', '1');
    return Promise.resolve();
  }
  PLOTS.dashboard = dashboard;

  function start() {
    makeSortable(document);
    var node = document.getElementById('tuner-data');
    var data = node ? JSON.parse(node.textContent) : {};
    [].forEach.call(document.querySelectorAll('div.tuner-plot[data-plot]'), function (div) {
      var name = div.getAttribute('data-plot'), fn = PLOTS[name], slot = data[name];
      if (!fn) { console.error('tuner: no plot named ' + name); return; }
      if (slot === undefined) { console.error('tuner: plot ' + name + ': no data'); return; }
      if (typeof Plotly === 'undefined') {
        console.error('tuner: plotly.min.js did not load');
        return;
      }
      try {
        Promise.resolve(fn(div, slot)).catch(function (e) { console.error('tuner: plot ' + name + ': ' + e); });
      } catch (e) {
        console.error('tuner: plot ' + name + ': ' + e);
      }
    });
  }

  if (document.readyState === 'loading') { document.addEventListener('DOMContentLoaded', start); }
  else { start(); }
}());
