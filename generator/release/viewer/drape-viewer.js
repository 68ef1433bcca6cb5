// drape gallery: the interactive 3D view of one entry — its hung mesh (anchor marked)
// and its fused mesh side by side; drag to turn, wheel to zoom, right-drag to pan,
// checkboxes to toggle each mesh, wireframe and overlay.
//
// Works from file:// (where pages cannot fetch() local files): each entry's meshes come
// as viewer/meshes/<id>.js, a classic script calling drapeViewerData(id, {...}) with the
// entry's hang.ply / recon.ply bytes gzipped and in base64, inflated here
// (DecompressionStream) and parsed by three.js's PLYLoader. The
// three.js files (npm "three", pinned) are loaded on first use, from viewer/.
(function () {
  'use strict';
  var waiting = {}, data = {}, libs = null, view = null;

  function script(src) {
    return new Promise(function (resolve, reject) {
      var s = document.createElement('script');
      s.src = src;
      s.onload = resolve;
      s.onerror = function () { reject(new Error('cannot load ' + src)); };
      document.head.appendChild(s);
    });
  }
  function loadLibs() {
    if (!libs) {
      libs = script('viewer/three.min.js')
        .then(function () { return script('viewer/PLYLoader.js'); })
        .then(function () { return script('viewer/OrbitControls.js'); });
    }
    return libs;
  }
  // Called by viewer/meshes/<id>.js.
  window.drapeViewerData = function (id, d) {
    data[id] = d;
    if (waiting[id]) { waiting[id](d); delete waiting[id]; }
  };
  function loadData(id) {
    if (data[id]) return Promise.resolve(data[id]);
    return new Promise(function (resolve, reject) {
      waiting[id] = resolve;
      script('viewer/meshes/' + encodeURIComponent(id) + '.js').catch(reject);
    });
  }
  // base64 → gzip → the PLY file's bytes (a Promise of an ArrayBuffer).
  function bytes(b64) {
    var s = atob(b64), a = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) a[i] = s.charCodeAt(i);
    var inflated = new Blob([a]).stream().pipeThrough(new DecompressionStream('gzip'));
    return new Response(inflated).arrayBuffer();
  }
  function status(text) { document.getElementById('v3d-status').textContent = text; }

  function buildDom() {
    var o = document.createElement('div');
    o.id = 'v3d';
    o.innerHTML =
      '<div id="v3d-bar"><b id="v3d-title"></b> ' +
      '<label><input type="checkbox" id="v3d-hang" checked> hung mesh (anchor in red)</label> ' +
      '<label><input type="checkbox" id="v3d-recon" checked> fused mesh</label> ' +
      '<label><input type="checkbox" id="v3d-wire"> wireframe</label> ' +
      '<label><input type="checkbox" id="v3d-overlay"> overlay</label> ' +
      '<span id="v3d-status"></span> <button id="v3d-close">close</button></div>' +
      '<div id="v3d-labels"><span>hung (simulated)</span><span>fused (TSDF of the depth sweep)</span></div>' +
      '<canvas id="v3d-canvas"></canvas>';
    document.body.appendChild(o);
    document.getElementById('v3d-close').onclick = close;
    ['v3d-hang', 'v3d-recon', 'v3d-wire', 'v3d-overlay'].forEach(function (k) {
      document.getElementById(k).onchange = function () { if (view) { apply(); render(); } };
    });
    window.addEventListener('resize', function () { if (view) render(); });
    return o;
  }

  function meshOf(buf, color, opacity) {
    var g = new THREE.PLYLoader().parse(buf);
    g.computeVertexNormals();
    var m = new THREE.MeshStandardMaterial({ color: color, roughness: 0.8, side: THREE.DoubleSide,
                                             transparent: opacity < 1, opacity: opacity });
    return new THREE.Mesh(g, m);
  }
  function lit(scene) {
    scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 0.9));
    var d = new THREE.DirectionalLight(0xffffff, 0.6);
    d.position.set(1, 2, 3);
    scene.add(d);
  }

  function make(id, d, hangPly, reconPly) {
    var canvas = document.getElementById('v3d-canvas');
    var renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.autoClear = false;
    var hang = meshOf(hangPly, 0x4a7fc1, 1), recon = meshOf(reconPly, 0xd9a441, 1);
    var left = new THREE.Scene(), right = new THREE.Scene();
    lit(left); lit(right);
    left.add(hang); right.add(recon);
    var box = new THREE.Box3().setFromObject(hang).union(new THREE.Box3().setFromObject(recon));
    var size = box.getSize(new THREE.Vector3()).length(), centre = box.getCenter(new THREE.Vector3());
    var marker = null;
    var pos = hang.geometry.getAttribute('position');
    if (d.anchor_vertex >= 0 && d.anchor_vertex < pos.count) {
      marker = new THREE.Mesh(new THREE.SphereGeometry(0.015 * size, 16, 12),
                              new THREE.MeshBasicMaterial({ color: 0xe02020 }));
      marker.position.fromBufferAttribute(pos, d.anchor_vertex);
      left.add(marker);
    }
    var camera = new THREE.PerspectiveCamera(35, 1, size / 100, size * 20);
    camera.position.copy(centre).add(new THREE.Vector3(0.45 * size, 0.25 * size, 1.5 * size));
    var controls = new THREE.OrbitControls(camera, canvas);
    controls.target.copy(centre);
    controls.update();
    controls.addEventListener('change', render);
    view = { id: id, renderer: renderer, camera: camera, controls: controls, left: left, right: right,
             hang: hang, recon: recon, marker: marker, reconClone: null };
    view.reconClone = recon.clone();
    view.reconClone.material = recon.material.clone();
    view.reconClone.material.transparent = true;
    view.reconClone.material.opacity = 0.45;
    apply(); render();
  }

  function checked(k) { return document.getElementById(k).checked; }
  function apply() {
    view.hang.visible = checked('v3d-hang');
    if (view.marker) view.marker.visible = checked('v3d-hang');
    view.recon.visible = checked('v3d-recon');
    view.hang.material.wireframe = view.recon.material.wireframe = checked('v3d-wire');
    view.reconClone.material.wireframe = checked('v3d-wire');
    var overlay = checked('v3d-overlay');
    if (overlay && !view.reconClone.parent) view.left.add(view.reconClone);
    if (!overlay && view.reconClone.parent) view.left.remove(view.reconClone);
    view.reconClone.visible = checked('v3d-recon');
    document.getElementById('v3d-labels').style.display = overlay ? 'none' : '';
  }
  // The drawing buffer follows the canvas's laid-out size (set on every render, so
  // that a late layout or a window resize never stretches the picture).
  function resize() {
    var c = view.renderer.domElement, w = c.clientWidth, h = c.clientHeight;
    var px = view.renderer.getPixelRatio();
    if (c.width !== Math.floor(w * px) || c.height !== Math.floor(h * px)) view.renderer.setSize(w, h, false);
  }
  function render() {
    resize();
    var r = view.renderer, c = r.domElement, w = c.clientWidth, h = c.clientHeight;
    var overlay = checked('v3d-overlay');
    r.setScissorTest(true);
    r.setClearColor(0xf4f4f4);
    var halves = overlay ? [[0, w, view.left]] : [[0, w / 2, view.left], [w / 2, w / 2, view.right]];
    view.camera.aspect = (overlay ? w : w / 2) / h;
    view.camera.updateProjectionMatrix();
    halves.forEach(function (p) {
      r.setViewport(p[0], 0, p[1], h);
      r.setScissor(p[0], 0, p[1], h);
      r.clear();
      r.render(p[2], view.camera);
    });
    r.setScissorTest(false);
  }

  // Non-background pixels drawn (read back from the canvas): for tests and the status line.
  function drawnPixels() {
    var gl = view.renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    var px = new Uint8Array(w * h * 4), n = 0;
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    for (var i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - 244) + Math.abs(px[i + 1] - 244) + Math.abs(px[i + 2] - 244) > 24) n++;
    }
    return n;
  }

  function close() {
    if (view) {
      view.controls.dispose();
      view.renderer.dispose();
      view = null;
    }
    var o = document.getElementById('v3d');
    if (o) o.parentNode.removeChild(o);
    document.body.style.overflow = '';
    if (/(^#|&)view=/.test(location.hash)) history.replaceState(null, '', location.pathname + location.search);
  }

  // Opens the 3D view of entry `id` (the 3D button of a card, or index.html#view=<id>).
  window.drapeOpen3d = function (id) {
    close();
    buildDom();
    document.getElementById('v3d-title').textContent = id;
    status('loading…');
    document.body.style.overflow = 'hidden';
    Promise.all([loadLibs(), loadData(id)]).then(function (r) {
      return Promise.all([r[1], bytes(r[1].hang), bytes(r[1].recon)]);
    }).then(function (r) {
      make(id, r[0], r[1], r[2]);
      // Once laid out: draw at the final size and report what was drawn.
      setTimeout(function () {
        if (!view) return;
        render();
        var c = view.renderer.domElement;
        var info = 'canvas ' + c.width + 'x' + c.height + ', drawn ' + drawnPixels() + ' px';
        status(info);
        document.getElementById('v3d').setAttribute('data-ready', info);
      }, 50);
    }).catch(function (e) {
      status('cannot show the 3D view: ' + e.message);
      console.error(e);
    });
  };
  document.addEventListener('keydown', function (e) { if (e.key === 'Escape') close(); });
})();
