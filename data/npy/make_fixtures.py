#!/usr/bin/python3
"""Writes the .npy fixtures of tests/test_npy.cpp with numpy (run here: /usr/bin/python3 make_fixtures.py).
3 rows x 4 columns, value = 100*row + column (row 0 first, i.e. north)."""
import numpy as np

base = 100 * (np.arange(12).reshape(3, 4) // 4) + np.arange(12).reshape(3, 4) % 4
np.save('f4_3x4.npy', (base + 0.25).astype('<f4'))
np.save('f8_3x4.npy', (base + 0.25).astype('<f8'))
np.save('i2_3x4.npy', (base - 150).astype('<i2'))
np.save('u2_3x4.npy', (base + 60000).astype('<u2'))
np.save('fortran_3x4.npy', np.asfortranarray((base + 0.25).astype('<f4')))
np.save('big_endian_3x4.npy', (base + 0.25).astype('>f4'))
np.save('shape_3d.npy', np.zeros((2, 3, 4), dtype='<f4'))
np.save('i4_3x4.npy', base.astype('<i4'))
with open('f4_v2_3x4.npy', 'wb') as f:  # numpy writes 2.0 only for huge headers: force it
    np.lib.format.write_array(f, (base + 0.25).astype('<f4'), version=(2, 0))
