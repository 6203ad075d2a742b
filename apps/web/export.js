// SPDX-License-Identifier: Apache-2.0
// The studio's Export dialog: the terrain in a format and an engine size, with the masks the
// session can make as 16-bit PNGs (POST /api/export {name, format, preset, masks}; docs/studio.md).
const $ = (id) => document.getElementById(id);
const PRESETS = ['unreal-505', 'unreal-1009', 'unreal-2017', 'unreal-4033', 'unreal-8129',
                 'unity-513', 'unity-1025', 'unity-2049', 'unity-4097'];
// Which operation a mask needs in the script (none: any terrain has it).
const MASKS = { flow: null, slope: null, wear: 'erode', deposition: 'erode', water: 'lake' };

export function initExport({ api, status, getState }) {
  const dlg = $('export_dialog');
  const preset = $('x_preset');
  for (const p of PRESETS) { const o = document.createElement('option'); o.value = p; o.textContent = p; preset.append(o); }
  const masks = $('x_masks');
  for (const m of Object.keys(MASKS)) {
    const l = document.createElement('label');
    l.innerHTML = `<input type="checkbox" id="x_mask_${m}" value="${m}"> ${m}`;
    masks.append(l);
  }
  $('export').onclick = () => {
    const ops = (getState() || { operations: [] }).operations.filter((o) => o.enabled !== false).map((o) => o.op);
    for (const [m, need] of Object.entries(MASKS)) {
      const box = $('x_mask_' + m), ok = !need || ops.includes(need);
      box.disabled = !ok;
      if (!ok) box.checked = false;
      box.parentElement.title = ok ? '' : `needs a ${need} layer`;
    }
    $('x_status').textContent = '';
    dlg.showModal();
  };
  $('x_close').onclick = () => dlg.close();
  $('x_go').onclick = async () => {
    const body = { name: $('x_name').value.trim(), format: $('x_format').value,
                   masks: Object.keys(MASKS).filter((m) => $('x_mask_' + m).checked) };
    if ($('x_preset').value) body.preset = $('x_preset').value;
    if (!body.name) { $('x_status').textContent = 'type a name'; return; }
    $('x_status').textContent = 'exporting (the script is replayed from the base)...';
    $('x_go').disabled = true;
    try {
      const r = await api('POST', '/api/export', body);
      const files = (r.written || []).map((p) => p.split('/').pop());
      $('x_status').textContent = 'wrote ' + files.join(', ');
      status('exported ' + files.join(', '));
    } catch (e) {
      $('x_status').textContent = 'error: ' + e.message;
    } finally {
      $('x_go').disabled = false;
    }
  };
}
