(function () {
  var svg = document.querySelector('#curves svg');
  if (!svg) { console.log('ragdoll report: no curves'); return; }
  var hidden = {};
  function apply() {
    svg.querySelectorAll('[data-run]').forEach(function (el) {
      var off = hidden[el.getAttribute('data-run')] === true;
      if (el.classList.contains('legend-item')) el.classList.toggle('off', off);
      else el.classList.toggle('hidden', off);
    });
  }
  svg.querySelectorAll('.legend-item').forEach(function (item) {
    item.addEventListener('click', function () {
      var run = item.getAttribute('data-run');
      hidden[run] = !hidden[run];
      apply();
    });
  });
  function runName(run) {
    var t = svg.querySelector('.legend-item[data-run="' + run + '"] text');
    return t ? t.textContent : 'run ' + run;
  }
  function short(v) { return Math.abs(v) >= 1000 ? Math.round(v).toString() : v.toPrecision(3); }
  var readout = document.getElementById('readout');
  var panels = svg.querySelectorAll('g.panel');
  var lines = 0;
  panels.forEach(function (panel) {
    var d = function (k) { return parseFloat(panel.getAttribute('data-' + k)); };
    var left = d('left'), right = d('right'), top = d('top'), bottom = d('bottom');
    var xMax = d('x-max'), yMax = d('y-max');
    var series = Array.prototype.map.call(panel.querySelectorAll('polyline'), function (pl) {
      lines++;
      var pts = pl.getAttribute('points').trim().split(/\s+/).map(function (p) {
        var xy = p.split(','); return [parseFloat(xy[0]), parseFloat(xy[1])];
      });
      return { run: pl.getAttribute('data-run'), points: pts };
    });
    var cursor = document.createElementNS(svg.namespaceURI, 'line');
    cursor.setAttribute('y1', top); cursor.setAttribute('y2', bottom);
    cursor.setAttribute('stroke', '#888'); cursor.setAttribute('stroke-dasharray', '3 3');
    cursor.style.display = 'none';
    panel.appendChild(cursor);
    var frame = panel.querySelector('rect.frame');
    frame.addEventListener('mousemove', function (ev) {
      var p = svg.createSVGPoint(); p.x = ev.clientX; p.y = ev.clientY;
      var q = p.matrixTransform(panel.getScreenCTM().inverse());
      var best = {};
      series.forEach(function (s) {
        if (hidden[s.run]) return;
        s.points.forEach(function (pt) {
          var dist = Math.abs(pt[0] - q.x);
          if (!best[s.run] || dist < best[s.run].dist) best[s.run] = { dist: dist, pt: pt };
        });
      });
      var x = (q.x - left) / (right - left) * xMax;
      var text = panel.getAttribute('data-title') + '<br>at ' + short(x) + ' ' +
          panel.getAttribute('data-x-unit');
      Object.keys(best).forEach(function (run) {
        var pt = best[run].pt;
        var xv = (pt[0] - left) / (right - left) * xMax;
        var yv = (bottom - pt[1]) / (bottom - top) * yMax;
        text += '<br>' + runName(run).replace(/</g, '&lt;') + ': ' + short(yv) + ' (at ' + short(xv) + ')';
      });
      readout.innerHTML = text;
      readout.style.display = 'block';
      readout.style.left = (ev.clientX + 14) + 'px';
      readout.style.top = (ev.clientY + 14) + 'px';
      cursor.setAttribute('x1', q.x); cursor.setAttribute('x2', q.x);
      cursor.style.display = '';
    });
    frame.addEventListener('mouseleave', function () {
      readout.style.display = 'none';
      cursor.style.display = 'none';
    });
  });
  console.log('ragdoll report: ' + panels.length + ' plots, ' + lines + ' lines');
})();
