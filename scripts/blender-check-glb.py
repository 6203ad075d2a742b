# SPDX-License-Identifier: Apache-2.0
import numpy
if not hasattr(numpy, "bool"): numpy.bool = bool  # Debian: Blender 3.4 importer vs numpy >= 1.24
import bpy, json
for o in list(bpy.data.objects): bpy.data.objects.remove(o)
bpy.ops.import_scene.gltf(filepath='/tmp/me/b.glb')
o = [x for x in bpy.context.scene.objects if x.type == 'MESH'][0]
me = o.data
print('BLENDER-CHECK object', o.name, 'vertices', len(me.vertices), 'polygons', len(me.polygons), 'uv', list(me.uv_layers.keys()))
print('BLENDER-CHECK custom props', sorted(k for k in o.keys()))
orig = o.get('origin')
print('BLENDER-CHECK origin', dict(orig) if orig is not None else None, 'epsg', o.get('epsg'))
xs = [v.co.x for v in me.vertices]; ys = [v.co.y for v in me.vertices]; zs = [v.co.z for v in me.vertices]
print('BLENDER-CHECK bounds x %.1f..%.1f y %.1f..%.1f z %.1f..%.1f' % (min(xs), max(xs), min(ys), max(ys), min(zs), max(zs)))
uv = me.uv_layers[0].data
us = [d.uv[0] for d in uv]; vs = [d.uv[1] for d in uv]
print('BLENDER-CHECK uv range u %.4f..%.4f v %.4f..%.4f' % (min(us), max(us), min(vs), max(vs)))
