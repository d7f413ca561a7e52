"""The field files open in ParaView's own Python (``pvpython``; Debian's ``python3-paraview``).

Behind the ``paraview`` marker: ``pytest -m paraview`` (``.ci/run`` installs ParaView where it is
missing). ParaView reads each frame with VTK's own XML reader, independently of the writer's
library: the cells, the arrays and their values must be what meshio reads from the same files.
"""

import json
import shutil
import subprocess

import meshio
import numpy as np
import pytest

from dsmv.cel import fields
from tests.test_end_to_end import job_dirs

pytestmark = pytest.mark.paraview

#: run by pvpython: the collection's times, and each frame's cells and cell arrays (first values)
READ_IN_PARAVIEW = """
import json, sys
from paraview import servermanager
from paraview.simple import OpenDataFile
from vtk.numpy_interface import dataset_adapter as dsa

series = OpenDataFile(sys.argv[1])
series.UpdatePipeline()
times = list(series.TimestepValues)
frames = {}
for path in sys.argv[2:]:
    reader = OpenDataFile(path)
    reader.UpdatePipeline()
    data = dsa.WrapDataObject(servermanager.Fetch(reader))
    frames[path] = {
        "cells": int(data.GetNumberOfCells()),
        "cell_type": int(data.GetCellType(0)),
        "arrays": {name: [float(v) for v in data.CellData[name].ravel()[:50]] for name in data.CellData.keys()},
    }
print(json.dumps({"times": times, "frames": frames}))
"""

#: VTK's cell types: a quad (2D frames), a hexahedron (3D frames)
VTK_QUAD, VTK_HEXAHEDRON = 9, 12


def _pvpython() -> str:
    path = shutil.which("pvpython")
    if path is None:
        pytest.fail("pvpython is not on the PATH: apt-get install python3-paraview (Debian's ParaView)")
    return path


@pytest.mark.parametrize("scene, cell_type", [
    (("solver=cel2d", "soil.law=tresca", "mesh=coarse"), VTK_QUAD),
    (("geometry=rectangular_plate", "soil.law=tresca", "mesh.cell_size_m=0.25"), VTK_HEXAHEDRON),
], ids=["2d_landing", "3d_plate_landing"])
def test_field_files_open_in_paraview_as_written(run_cli, tmp_path, scene, cell_type):
    proc = run_cli("dsmv", *scene, "output.fields=true", "output.field_frames=3", "tracking=disabled",
                   "output.plots=false")
    assert proc.returncode == 0, proc.stderr
    (job,) = job_dirs(tmp_path)
    frames = fields.series(job)
    paths = [str(frames[0][1]), str(frames[-1][1]), str(job / fields.MAX_SINKAGE_FRAME)]
    read = subprocess.run([_pvpython(), "-c", READ_IN_PARAVIEW, str(job / fields.FIELDS_FILE), *paths],
                          capture_output=True, text=True, timeout=300)
    assert read.returncode == 0, read.stderr
    seen = json.loads(read.stdout.strip().splitlines()[-1])
    # the collection's times are the frames' own (the deepest frame shares its time with another)
    assert seen["times"] == pytest.approx(sorted({t for t, _ in frames}), rel=1e-12)
    for path in paths:
        frame, mesh = seen["frames"][path], meshio.read(path)
        assert frame["cells"] == sum(len(block.data) for block in mesh.cells)
        assert frame["cell_type"] == cell_type
        assert set(frame["arrays"]) == set(mesh.cell_data)
        for name, values in frame["arrays"].items():
            expected = np.concatenate(mesh.cell_data[name]).ravel()[:len(values)]
            assert np.array_equal(np.asarray(values), expected.astype(float)), name
