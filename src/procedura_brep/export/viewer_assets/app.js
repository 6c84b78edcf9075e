/* procedura-brep offline viewer (docs/viewer.md): the part tree, a slider per joint, an exploded
 * view, mate frames and the run's findings. A classic script: it reads the globals THREE
 * (viewer/three.min.js), PROCEDURA_VIEWER (viewer/data.js) and PROCEDURA_FINDINGS
 * (viewer/findings.js), so the page works from file:// with no network.
 *
 * Scene graph: one node per link (matrix = its rest matrix in the parent link, times the joint's
 * motion: a turn about the link's +Z, a slide along it, as the URDF's joints), under it one mesh
 * per part (matrix = the part's placement in the link, after the exploded view's offset). All
 * matrices are set directly (matrixAutoUpdate off), so a part's world matrix at rest is exactly
 * its placement. Units: mm, +Z up. */
(function () {
  'use strict';
  const T = window.THREE;
  const DATA = window.PROCEDURA_VIEWER;
  const FINDINGS = window.PROCEDURA_FINDINGS || { status: null, findings: [] };
  const $ = (id) => document.getElementById(id);
  const el = (tag, cls, text) => {
    const e = document.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    return e;
  };

  const state = { values: {}, explode: 0, frames: false, hidden: new Set(), isolated: null,
                  selected: null };
  const partNodes = {};   // part name -> THREE.Mesh
  const linkNodes = {};   // link name -> node
  const partRows = {};    // part name -> tree row
  const sliders = {};     // dof name -> {input, value, dof}
  const triads = [];
  const partByName = {};
  DATA.parts.forEach((p) => { partByName[p.name] = p; });

  const viewer = window.viewer = {
    ready: false, firstFrameMs: null, lit: false, litFrameMs: null, gl: false, data: DATA,
    findings: FINDINGS,
    parts: () => DATA.parts.map((p) => p.name),
    node: (name) => partNodes[name],
    worldMatrix: (name) => { scene.updateMatrixWorld(true); return partNodes[name].matrixWorld.toArray(); },
    linkWorldMatrix: (name) => { scene.updateMatrixWorld(true); return linkNodes[name].matrixWorld.toArray(); },
    visible: (name) => partNodes[name].visible,
    selected: () => state.selected,
    isolated: () => (state.isolated ? Array.from(state.isolated) : null),
    setJoint: (dof, value) => setDof(dof, value),
    render: () => render(),
  };

  // ---- the scene -------------------------------------------------------------------------
  const scene = new T.Scene();
  scene.background = new T.Color(0xe9ebee);
  const camera = new T.PerspectiveCamera(35, 1, 1, 1e6);
  camera.up.set(0, 0, 1);
  const view = $('view');
  let renderer = null;
  try {
    renderer = new T.WebGLRenderer({ antialias: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    view.appendChild(renderer.domElement);
    viewer.gl = true;
  } catch (err) {
    const msg = el('div', null, 'WebGL is not available in this browser: the 3D view is off ' +
                   '(the part tree, joints and findings still work).');
    msg.id = 'nogl';
    view.appendChild(msg);
  }
  scene.add(new T.HemisphereLight(0xffffff, 0x8a8a8a, 0.6));
  const sun = new T.DirectionalLight(0xffffff, 1.2);
  sun.position.set(1, -1.5, 2);
  scene.add(sun);

  const mat4 = (a) => new T.Matrix4().fromArray(a);
  const geometryOf = (p) => {
    const bytes = (b64) => {
      const bin = atob(b64);
      const out = new Uint8Array(bin.length);
      for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
      return out.buffer;
    };
    const g = new T.BufferGeometry();
    g.setAttribute('position', new T.BufferAttribute(new Float32Array(bytes(p.positions)), 3));
    g.setAttribute('normal', new T.BufferAttribute(new Int8Array(bytes(p.normals)), 3, true));
    const idx = bytes(p.indices);
    g.setIndex(new T.BufferAttribute(p.index_bytes === 2 ? new Uint16Array(idx) : new Uint32Array(idx), 1));
    g.computeBoundingSphere();
    return g;
  };

  const links = {};
  DATA.links.forEach((lk) => {
    links[lk.name] = lk;
    const node = new T.Group();
    node.name = 'link:' + lk.name;
    node.matrixAutoUpdate = false;
    node.userData.rest = mat4(lk.rest);
    node.matrix.copy(node.userData.rest);
    (lk.parent ? linkNodes[lk.parent] : scene).add(node);
    linkNodes[lk.name] = node;
  });
  DATA.parts.forEach((p) => {
    const material = new T.MeshStandardMaterial({
      color: new T.Color().setRGB(p.rgb[0], p.rgb[1], p.rgb[2], T.SRGBColorSpace),
      metalness: p.metalness, roughness: p.roughness });
    const mesh = new T.Mesh(geometryOf(p), material);
    mesh.name = p.name;
    mesh.matrixAutoUpdate = false;
    mesh.userData = { part: p.name, local: mat4(p.local), center: new T.Vector3().fromArray(p.center) };
    mesh.matrix.copy(mesh.userData.local);
    linkNodes[p.link].add(mesh);
    partNodes[p.name] = mesh;
  });
  scene.updateMatrixWorld(true);

  // the model's size and centre at rest (the exploded view pushes parts away from the centre)
  const box = new T.Box3();
  DATA.parts.forEach((p) => box.expandByObject(partNodes[p.name]));
  const size = box.isEmpty() ? 100 : box.getSize(new T.Vector3()).length();
  const centre = box.isEmpty() ? new T.Vector3() : box.getCenter(new T.Vector3());

  DATA.mates.forEach((m) => {
    const owner = partNodes[m.parent];
    if (!owner) return;
    const axes = new T.AxesHelper(0.06 * size);
    axes.name = 'mate:' + m.name;
    axes.matrixAutoUpdate = false;
    axes.matrix.copy(mat4(m.in_parent));
    axes.material.depthTest = false;
    axes.renderOrder = 10;
    axes.visible = false;
    owner.add(axes);
    triads.push(axes);
  });

  // ---- pose, explode, visibility -----------------------------------------------------------
  const motion = (dof, value) => {
    const m = new T.Matrix4();
    if (dof.motion === 'slide') return m.makeTranslation(0, 0, value);
    return m.makeRotationZ(value * Math.PI / 180);
  };
  const dofsOf = {};
  DATA.joints.forEach((j) => { dofsOf[j.child] = j; });

  function pose() {
    DATA.links.forEach((lk) => {
      const node = linkNodes[lk.name];
      node.matrix.copy(node.userData.rest);
      const j = dofsOf[lk.name];
      if (!j) return;
      j.dofs.forEach((d) => node.matrix.multiply(motion(d, state.values[d.name] || 0)));
    });
    DATA.parts.forEach((p) => partNodes[p.name].matrix.copy(partNodes[p.name].userData.local));
    scene.updateMatrixWorld(true);
    if (state.explode > 0) {
      const rot = new T.Matrix4();
      DATA.parts.forEach((p) => {
        const mesh = partNodes[p.name];
        const at = mesh.userData.center.clone().applyMatrix4(mesh.matrixWorld);
        const push = at.sub(centre).multiplyScalar(state.explode);
        // the push in the link's axes: the inverse of its (rigid) world rotation
        rot.extractRotation(mesh.parent.matrixWorld).transpose();
        push.applyMatrix4(rot);
        mesh.matrix.premultiply(new T.Matrix4().makeTranslation(push.x, push.y, push.z));
      });
      scene.updateMatrixWorld(true);
    }
  }

  function applyVisibility() {
    DATA.parts.forEach((p) => {
      const shown = !state.hidden.has(p.name) && (!state.isolated || state.isolated.has(p.name));
      partNodes[p.name].visible = shown;
      const row = partRows[p.name];
      row.classList.toggle('dim', !shown);
      row.querySelector('input').checked = !state.hidden.has(p.name);
    });
    triads.forEach((t) => { t.visible = state.frames; });
  }

  function select(name) {
    state.selected = partByName[name] ? name : null;
    DATA.parts.forEach((p) => {
      const on = p.name === state.selected;
      partRows[p.name].classList.toggle('selected', on);
      partNodes[p.name].material.emissive.setHex(on ? 0x2244aa : 0x000000);
    });
    if (state.selected) partRows[state.selected].scrollIntoView({ block: 'nearest' });
  }

  function isolate(names) {
    const keep = names.filter((n) => partByName[n]);
    state.isolated = keep.length ? new Set(keep) : null;
    applyVisibility();
  }

  // a joint a coupling drives follows the joint at the head of its chain (a gear, a rack, a
  // screw, a belt: value = offset + ratio * driver's value, as the URDF's <mimic>)
  function follow() {
    DATA.joints.forEach((j) => j.dofs.forEach((d) => {
      if (!d.driver) return;
      state.values[d.name] = d.offset + d.ratio * (state.values[d.driver] || 0);
      const s = sliders[d.name];
      if (s) {
        s.input.value = String(state.values[d.name]);
        s.value.textContent = fmt(state.values[d.name]) + ' ' + d.unit;
      }
    }));
  }

  function update() { follow(); pose(); applyVisibility(); render(); }

  // ---- the panel ---------------------------------------------------------------------------
  document.title = DATA.name + ' - procedura-brep viewer';
  $('title').textContent = DATA.name;
  const status = $('status');
  if (FINDINGS.status) {
    status.textContent = 'status: ' + FINDINGS.status + ' - ' + DATA.parts.length + ' parts, ' +
      DATA.joints.length + ' joints';
    status.className = FINDINGS.status === 'ok' ? 'status-ok' : 'status-bad';
  } else {
    status.textContent = DATA.parts.length + ' parts, ' + DATA.joints.length + ' joints';
  }

  const tree = $('tree');
  function treeOf(linkName, depth) {
    const lk = links[linkName];
    const head = el('div', 'link-row');
    head.style.marginLeft = (depth * 12) + 'px';
    head.appendChild(el('span', null, lk.name));
    const j = dofsOf[lk.name];
    head.appendChild(el('span', 'joint', j ? '  ' + j.name + ' (' + j.type + ')' : '  root (' + DATA.base + ')'));
    tree.appendChild(head);
    lk.parts.forEach((name) => {
      const p = partByName[name];
      const row = el('div', 'part-row');
      row.dataset.part = name;
      row.style.marginLeft = (depth * 12 + 6) + 'px';
      row.title = (p.description || name) + (p.block_of ? ' (colour block on ' + p.block_of + ')' : '') +
        '\nclick: isolate (click again: show all); box: show or hide';
      const box = el('input');
      box.type = 'checkbox';
      box.checked = true;
      box.title = 'show or hide ' + name;
      box.addEventListener('click', (ev) => ev.stopPropagation());
      box.addEventListener('change', () => {
        if (box.checked) state.hidden.delete(name); else state.hidden.add(name);
        applyVisibility(); render();
      });
      const swatch = el('span', 'swatch');
      swatch.style.background = 'rgb(' + p.rgb.map((c) => Math.round(c * 255)).join(',') + ')';
      row.append(box, swatch, el('span', 'name', name), el('span', 'mat', p.material));
      row.addEventListener('click', () => {
        const only = state.isolated && state.isolated.size === 1 && state.isolated.has(name);
        select(name);
        isolate(only ? [] : [name]);
        render();
      });
      tree.appendChild(row);
      partRows[name] = row;
    });
    DATA.joints.filter((jj) => jj.parent === linkName).forEach((jj) => treeOf(jj.child, depth + 1));
  }
  if (DATA.links.length) treeOf(DATA.links[0].name, 0);
  $('show-all').addEventListener('click', () => { state.hidden.clear(); isolate([]); render(); });

  const fmt = (v) => (Math.abs(v) < 5e-5 ? 0 : v).toFixed(1);
  function setDof(name, value) {
    const s = sliders[name];
    if (!s) throw new Error('no joint slider named ' + name);
    s.input.value = String(value);
    state.values[name] = Number(s.input.value);
    s.value.textContent = fmt(state.values[name]) + ' ' + s.dof.unit;
    update();
  }
  const jointsBox = $('joints');
  if (DATA.note) jointsBox.appendChild(el('div', 'note', DATA.note));
  else if (!DATA.joints.length) jointsBox.appendChild(el('div', 'note', 'no joints: every mate is static'));
  DATA.joints.forEach((j) => {
    if (j.note) jointsBox.appendChild(el('div', 'note', j.name + ': ' + j.note));
    j.dofs.forEach((d) => {
      const box = el('div', 'dof');
      const label = el('div', 'label');
      const value = el('span', 'value', '0.0 ' + d.unit);
      label.append(el('span', null, d.name + ' (' + (d.driver ? d.coupling + ' from ' + d.driver : d.type) + ')'), value);
      const input = el('input');
      input.type = 'range';
      input.min = String(d.lower);
      input.max = String(d.upper);
      input.step = 'any';
      input.value = '0';
      input.dataset.dof = d.name;
      if (d.driver) {  // moved by its driver only
        input.disabled = true;
        input.dataset.driver = d.driver;
      }
      input.title = d.name + ': ' + fmt(d.lower) + ' to ' + fmt(d.upper) + ' ' + d.unit +
        (d.endless ? ' (no limits: one turn shown)' : '') + ', 0 = the compiled pose' +
        (j.flipped ? '; a wheel: positive rolls forward (axis = the mate frame\'s -Z)' : '') +
        (d.driver ? '; follows ' + d.driver + ': ' + fmt(d.offset) + ' + ' + d.ratio.toPrecision(6) +
         ' x ' + d.driver : '');
      input.addEventListener('input', () => {
        state.values[d.name] = Number(input.value);
        value.textContent = fmt(state.values[d.name]) + ' ' + d.unit;
        update();
      });
      box.append(label, input);
      jointsBox.appendChild(box);
      sliders[d.name] = { input, value, dof: d };
    });
  });
  $('reset').addEventListener('click', () => {
    Object.keys(sliders).forEach((n) => {
      sliders[n].input.value = '0';
      state.values[n] = 0;
      sliders[n].value.textContent = '0.0 ' + sliders[n].dof.unit;
    });
    update();
  });
  $('explode').addEventListener('input', (ev) => { state.explode = Number(ev.target.value); update(); });
  $('frames').addEventListener('change', (ev) => { state.frames = ev.target.checked; update(); });

  const findingsBox = $('findings');
  if (FINDINGS.note) findingsBox.appendChild(el('div', 'note', FINDINGS.note));
  if (!FINDINGS.findings.length) findingsBox.appendChild(el('div', 'note', 'none'));
  FINDINGS.findings.forEach((f) => {
    const sev = f.severity || 'error';
    const row = el('div', 'finding ' + sev);
    let names = [f.part, f.other].filter((n) => n && partByName[n]);
    const mate = DATA.mates.find((m) => m.name === f.mate);
    if (!names.length && mate) names = [mate.child, mate.parent];  // a mate's finding: its two parts
    row.dataset.part = f.part || '';
    row.append(el('span', 'code', '[' + sev + '] ' + (f.code || '?') + ': '), el('span', null, f.message || ''));
    if (f.part) row.append(el('div', 'note', 'part ' + f.part + (f.other ? ' and ' + f.other : '')));
    else if (f.mate) row.append(el('div', 'note', 'mate ' + f.mate));
    if (names.length) {
      row.title = 'click: select ' + names[0] + ' and show only ' + names.join(' and ');
      row.addEventListener('click', () => { select(names[0]); isolate(names); render(); });
    } else {
      row.classList.add('nopart');
      row.title = f.part ? 'part ' + f.part + ' is not in this model' : 'about the whole model';
    }
    findingsBox.appendChild(row);
  });

  // ---- camera, picking, rendering ----------------------------------------------------------
  let controls = null;
  function fit() {
    const b = new T.Box3();
    DATA.parts.forEach((p) => { if (partNodes[p.name].visible) b.expandByObject(partNodes[p.name]); });
    if (b.isEmpty()) return;
    const sphere = b.getBoundingSphere(new T.Sphere());
    const dist = sphere.radius / Math.sin(camera.fov * Math.PI / 360) * 1.1;
    const dir = new T.Vector3(1, -1.3, 0.9).normalize();  // from the front-right (front = -Y)
    camera.position.copy(sphere.center).addScaledVector(dir, dist);
    camera.near = Math.max(dist / 1000, 0.01);
    camera.far = dist * 100;
    camera.updateProjectionMatrix();
    if (controls) { controls.target.copy(sphere.center); controls.update(); }
    render();
  }
  function resize() {
    if (!renderer) return;
    const w = view.clientWidth || 1;
    const h = view.clientHeight || 1;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    render();
  }
  let started = false;  // no drawing while the page is set up: the first frame is the fitted one
  function render() {
    if (renderer && started) renderer.render(scene, camera);
  }
  if (renderer) {
    controls = new T.OrbitControls(camera, renderer.domElement);
    controls.addEventListener('change', render);
    const ray = new T.Raycaster();
    let down = null;
    renderer.domElement.addEventListener('pointerdown', (ev) => { down = [ev.clientX, ev.clientY]; });
    renderer.domElement.addEventListener('pointerup', (ev) => {
      if (!down || Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 4) return;
      const r = renderer.domElement.getBoundingClientRect();
      ray.setFromCamera(new T.Vector2((ev.clientX - r.left) / r.width * 2 - 1,
                                      -((ev.clientY - r.top) / r.height) * 2 + 1), camera);
      const hits = ray.intersectObjects(Object.values(partNodes).filter((m) => m.visible), false);
      select(hits.length ? hits[0].object.userData.part : null);
      render();
    });
    window.addEventListener('resize', resize);
  }
  $('fit').addEventListener('click', fit);
  // cb once the GPU has finished every command issued so far (a WebGL2 fence, polled: no
  // stall), so the times below are frames drawn, not draw calls issued
  function whenDrawn(cb) {
    const gl = renderer ? renderer.getContext() : null;
    if (!gl || !gl.fenceSync) { requestAnimationFrame(cb); return; }
    const sync = gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
    gl.flush();
    const poll = () => {
      if (gl.clientWaitSync(sync, 0, 0) === gl.TIMEOUT_EXPIRED) { setTimeout(poll, 2); return; }
      gl.deleteSync(sync);
      cb();
    };
    poll();
  }

  update();
  resize();
  started = true;
  fit();
  // first frame: lights only; then the image-based lighting (a PMREM of three's RoomEnvironment:
  // metals need it), whose shaders take a GPU moment (seconds in software GL), and a redraw
  whenDrawn(() => {
    viewer.firstFrameMs = performance.now();
    viewer.ready = true;
    if (!renderer) return;
    setTimeout(() => {
      const pmrem = new T.PMREMGenerator(renderer);
      scene.environment = pmrem.fromScene(new T.RoomEnvironment(), 0.04).texture;
      pmrem.dispose();
      render();
      whenDrawn(() => { viewer.litFrameMs = performance.now(); viewer.lit = true; });
    }, 0);
  });
})();
