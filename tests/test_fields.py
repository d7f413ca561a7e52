"""Field output (``output.fields``): VTU frames and a ParaView collection, contour PNGs; off by default."""

import json
import math
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from dsmv import registry
from dsmv.cel.grid import Grid2D
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError
from dsmv.cel import fields
from dsmv.post.plots import FIELD_PLOT_FILE
from tests.conftest import mlflow_runs
from tests.test_end_to_end import job_dirs

CELL_FIELDS = {
    "volume_fraction", "stress_xx_pa", "stress_yy_pa", "stress_xy_pa", "stress_zz_pa", "su_pa",
    "mobilised_strength", "plastic_shear_strain", "shear_strain_rate_per_s", "plastic_shear_strain_rate_per_s",
    "initial_depth_m", "hourglass_velocity_m_s", "body",
}
def keep_state(monkeypatch, solver_cls) -> dict:
    """The state the solver's run starts from, kept in the returned dict under "state" (the run then
    changes it in place: at the end it is the final state)."""
    captured = {}
    real = solver_cls.initial_state

    def keep(self):
        captured["state"] = real(self)
        return captured["state"]

    monkeypatch.setattr(solver_cls, "initial_state", keep)
    return captured


#: soil compressed by its load holds a little more than its cell at rest (φ > 1): the bulk
#: strain of a few tens of kPa on K ≈ 40 MPa (E = 500·su0, ν = 0.49) is about 1e-3
PHI_COMPRESSED = 1.01


def test_a_landing_with_fields_writes_a_paraview_series_and_contours(run_cli, tmp_path):
    frames_asked = 5
    # Tresca with the soil tied to the track: every soil cell carries its intact strength (a gap cell
    # of the no-tension contact carries none while it is partly full)
    proc = run_cli("dsmv", "solver=cel2d", "soil.law=tresca", "solver.contact_separation=false", "mesh=coarse",
                   "output.fields=true", f"output.field_frames={frames_asked}")
    assert proc.returncode == 0, proc.stderr
    (job,) = job_dirs(tmp_path)
    result = json.loads((job / "result.json").read_text())
    assert result["status"] == "ok"

    root = ET.parse(job / fields.FIELDS_FILE).getroot()
    assert root.get("type") == "Collection"
    frames = fields.series(job)
    times = [t for t, _ in frames]
    assert times[0] == 0.0 and all(np.diff(times) > 0)
    assert times[-1] == pytest.approx(result["metrics"]["time_to_rest_s"], rel=1e-9)
    # evenly spaced frames: N to 2N after t = 0, plus the end and the deepest instant
    assert frames_asked + 1 <= len(frames) <= 2 * frames_asked + 3
    assert job / fields.MAX_SINKAGE_FRAME in [p for _, p in frames]

    first = meshio.read(frames[0][1])
    for _, path in frames:
        mesh = meshio.read(path)
        n_cells = len(mesh.cells_dict["quad"])
        assert set(mesh.cell_data) == CELL_FIELDS
        assert all(len(v[0]) == n_cells for v in mesh.cell_data.values())
        assert mesh.point_data["velocity_m_s"].shape == (len(mesh.points), 3)
        phi = mesh.cell_data["volume_fraction"][0]
        assert phi.min() >= 0.0 and phi.max() <= PHI_COMPRESSED
        # each frame in the laboratory frame: the grid shifted down by the sinkage
        sinkage = mesh.field_data["sinkage_m"][0]
        assert mesh.points[:, 1].min() == pytest.approx(first.points[:, 1].min() - sinkage, abs=1e-9)
    deepest = meshio.read(job / fields.MAX_SINKAGE_FRAME)
    # the deepest chunk end: at most the deepest step, and the body was all but at rest there
    assert deepest.field_data["sinkage_m"][0] == pytest.approx(result["metrics"]["max_sinkage_m"], rel=1e-3)
    cells = {k: v[0] for k, v in deepest.cell_data.items()}
    soil = cells["volume_fraction"] > 0.5
    assert cells["plastic_shear_strain"][soil].max() > 0.1  # the soil under the track yielded
    # Tresca: su is the intact strength of where the soil came from
    su_intact = 5000.0 + 1500.0 * cells["initial_depth_m"]
    assert cells["su_pa"][soil] == pytest.approx(su_intact[soil], rel=1e-5)

    assert (job / FIELD_PLOT_FILE).stat().st_size > 10_000
    (run,) = mlflow_runs(tmp_path)
    from mlflow.tracking import MlflowClient

    client = MlflowClient(f"sqlite:///{(tmp_path / 'runs' / 'mlflow.db').resolve()}")
    logged = {a.path for a in client.list_artifacts(run.info.run_id)}
    assert {fields.FIELDS_FILE, fields.FIELDS_DIR, FIELD_PLOT_FILE} <= logged
    logged_frames = {a.path for a in client.list_artifacts(run.info.run_id, fields.FIELDS_DIR)}
    assert len(logged_frames) == len(frames)


@pytest.mark.parametrize("overrides", [["solver=cel2d", "solver.progress=off"], ["solver=analytic_energy", "output.fields=true"]],
                         ids=["cel2d_default", "analytic"])
def test_no_fields_by_default_nor_from_a_solver_without_them(compose_cfg, tmp_path, overrides):
    from dsmv.app.runner import write_outputs

    scene = build_scene(compose_cfg(["mesh=coarse", "tracking=disabled", *overrides]))
    solver = registry.load("solvers", scene.solver.name, "solver.name")(scene)
    files = write_outputs(scene, solver.solve(tmp_path), tmp_path)
    assert (tmp_path / "history.png") in files
    assert not (tmp_path / fields.FIELDS_FILE).exists() and not (tmp_path / fields.FIELDS_DIR).exists()
    assert not (tmp_path / FIELD_PLOT_FILE).exists()


def test_the_fields_show_the_kernels_own_strength(compose_cfg, tmp_path, monkeypatch):
    """A T-bar with α = 0.5: its interface layer has strength α·su (5 kPa of 10 kPa) in the stress
    update, and the field output shows that strength, not the intact one: su_pa is the kernel's own
    su cell by cell (float32 of it) and the interface cells that yield read a mobilised strength of 1."""
    from dsmv.cel.solver2d import Cel2DSolver

    captured = keep_state(monkeypatch, Cel2DSolver)
    scene = build_scene(compose_cfg(["experiment=verify_tbar", "hydra.mode=RUN", "geometry.roughness=0.5",
                                     "mesh.cell_size_m=0.05", "landing.displacement_m=0.05", "solver.progress=off",
                                     "tracking=disabled", "output.plots=false", "output.fields=true",
                                     "output.field_frames=2"]))
    assert Cel2DSolver(scene).solve(tmp_path).status == "ok"
    state = captured["state"]
    last = fields.read_frame(fields.series(tmp_path)[-1][1]).cells
    assert last["su_pa"] == pytest.approx(state.cells.su.astype(np.float32), rel=1e-6, abs=1e-3)
    layer = (state.cells.strength_factor == 0.5) & (last["volume_fraction"] > 0.99)
    assert layer.any() and last["su_pa"][layer] == pytest.approx(0.5 * scene.soil.su0_pa, rel=1e-6)
    assert last["mobilised_strength"][layer].max() == pytest.approx(1.0, rel=1e-5)


@pytest.mark.parametrize("axisym", [False, True])
def test_shear_strain_rate_of_known_flows(axisym):
    """The field's strain rate is the stress update's (dsmv.cel.kernels.elements2d.shear_strain_rates)."""
    from dsmv.cel.kernels.elements2d import cell_volumes, shear_strain_rates
    from dsmv.cel.state import Elastic, body_free_state, step_parameters

    x, y = np.linspace(0.1, 1.1, 6), np.linspace(-1.0, 0.0, 5)
    X, Y = np.meshgrid(x, y, indexing="ij")
    mesh, cells, faces, nodes, *_ = body_free_state(x, y, np.ones((5, 4)), np.zeros((6, 5, 4)),
                                                    cell_volumes(x, y, axisym))
    par = step_parameters(dt=1e-3, density=1.0, elastic=Elastic(1.0, 1.0, 1.0, 0.0), h=0.25, gravity=0.0, su0=1.0,
                          ks=0.0, hourglass=0.0, bulk_linear=0.0, bulk_quadratic=0.0, stress_cutoff=0.01,
                          axisymmetric=axisym, advection_order=2, drop=False, inflow=False, remap=True, tresca=False,
                          law_active=False)
    if axisym:  # isochoric radial flow: rates c (radial), c (hoop), −2c (vertical) → ε̇1 − ε̇3 = 3c
        c = 0.2
        nodes.v[0], nodes.v[1] = (c * X).ravel(), (-2 * c * Y).ravel()
        assert shear_strain_rates(mesh, cells, faces, nodes, par, 0.0) == pytest.approx(np.full((5, 4), 3 * c))
    else:  # simple shear v_x = a·y: principal rates ±a/2 → γ̇ = a
        a = 0.7
        nodes.v[0] = (a * Y).ravel()
        assert shear_strain_rates(mesh, cells, faces, nodes, par, 0.0) == pytest.approx(np.full((5, 4), a))


def test_a_run_of_any_length_keeps_n_to_2n_evenly_spaced_frames():
    grid = Grid2D(x=np.linspace(0, 1, 3), y=np.linspace(-1, 0, 3), h=0.5)
    phi, q = np.ones((2, 2)), np.zeros((6, 2, 2))
    su, rate, v = np.ones((2, 2)), np.zeros((2, 2)), np.zeros((2, 9))
    n, chunk = 4, 0.01
    for chunks in (3, 9, 50, 1000):
        recorder = fields.FieldRecorder(grid, np.zeros((2, 2), bool), None, tresca=False, stress_cutoff=0.01,
                                        frames=n, spacing_s=chunk)
        sinkage = lambda t: 1.0 - (t - 0.7 * chunks * chunk) ** 2  # deepest at 70 % of the run
        for k in range(chunks + 1):
            recorder.sample(k * chunk, sinkage(k * chunk), phi, q, su, rate, v)
        recorder.sample(chunks * chunk, sinkage(chunks * chunk), phi, q, su, rate, v, final=True)
        times = np.array([s.time_s for _, s in recorder.taken])
        assert times[0] == 0.0 and times[-1] == pytest.approx(chunks * chunk)
        assert min(chunks, n) <= len(times) - 1 <= 2 * n + 1
        gaps = np.diff(times[:-1])  # the last frame is the run's end, wherever that falls
        assert gaps == pytest.approx(np.full(len(gaps), gaps[0]))
        deepest = max(range(chunks + 1), key=lambda k: sinkage(k * chunk))
        assert recorder.deepest.time_s == pytest.approx(deepest * chunk)


@pytest.mark.parametrize("value", ["0", "-3", "1.5", "many"])
def test_field_frames_is_validated(compose_cfg, value):
    with pytest.raises(ConfigError, match=r"output\.field_frames"):
        build_scene(compose_cfg([f"output.field_frames={value}"]))


def test_a_run_that_goes_unstable_still_leaves_its_fields_and_contours(compose_cfg, tmp_path, monkeypatch):
    """The last frame holds the non-finite state (to look at in ParaView); the PNG draws what is finite."""
    from dsmv.cel import stepper, stepper2d
    from dsmv.app.runner import write_outputs

    real, calls = stepper2d.run_steps, {"n": 0}

    def poisoned(n_steps, *args):
        done, code = real(n_steps, *args)
        calls["n"] += 1
        if calls["n"] == 40:
            args[1].q[0, 3, 5] = np.nan  # cells: σxx goes NaN
            args[3].v[0, 20] = np.inf  # nodes: a velocity blows up
            return done, stepper.NOT_FINITE
        return done, code

    monkeypatch.setattr(stepper2d, "run_steps", poisoned)
    scene = build_scene(compose_cfg(["solver=cel2d", "mesh=coarse", "solver.progress=off", "tracking=disabled",
                                     "output.fields=true", "output.field_frames=3"]))
    result = registry.load("solvers", "cel2d", "solver.name")(scene).solve(tmp_path)
    assert result.status == "unstable"
    files = write_outputs(scene, result, tmp_path)
    assert tmp_path / FIELD_PLOT_FILE in files
    last = meshio.read(fields.series(tmp_path)[-1][1])
    assert not np.isfinite(last.cell_data["stress_xx_pa"][0]).all()


CELL_FIELDS_3D = CELL_FIELDS | {"stress_yz_pa", "stress_zx_pa"}


def test_a_3d_run_writes_hexahedra_and_both_sections(compose_cfg, tmp_path, monkeypatch):
    """A quarter square plate pushed into weightless Tresca soil (su 10 kPa) with the remap: hexahedral
    frames that read back cell for cell and node for node as the solver's state (φ, the body, the
    nodal velocities), whose strength is su, whose cells under the plate sit on Tresca's surface
    (mobilised strength 1: the field's principal stresses agree with the return's), shifted down by
    the sinkage, and the two sections' contour figures."""
    from dsmv.cel.solver3d import Cel3DSolver
    from dsmv.post.plots import LONGITUDINAL_SUFFIX
    from dsmv.app.runner import write_outputs
    from tests.test_cel3d import SMALL_STRAIN_PUSH

    captured = keep_state(monkeypatch, Cel3DSolver)
    overrides = [*SMALL_STRAIN_PUSH, "geometry=rectangular_plate", "geometry.width_m=1", "geometry.contact_length_m=1",
                 "mesh.cell_size_m=0.2", "solver.remap=true", "landing.displacement_m=0.05", "output.plots=true",
                 "output.fields=true", "output.field_frames=2"]
    scene = build_scene(compose_cfg(overrides))
    result = Cel3DSolver(scene).solve(tmp_path)
    assert result.status == "ok", result.message
    files = write_outputs(scene, result, tmp_path)
    frames = fields.series(tmp_path)
    assert len(frames) >= 3
    first = meshio.read(frames[0][1])
    for _, path in frames:
        mesh = meshio.read(path)
        (block,) = mesh.cells
        assert block.type == "hexahedron" and set(mesh.cell_data) == CELL_FIELDS_3D
        sinkage = mesh.field_data["sinkage_m"][0]
        assert mesh.points[:, 2].min() == pytest.approx(first.points[:, 2].min() - sinkage, abs=1e-9)
    state = captured["state"]
    last = fields.read_frame(frames[-1][1])
    assert last.cells["volume_fraction"] == pytest.approx(state.cells.phi.astype(np.float32), rel=1e-7, abs=1e-30)
    assert np.array_equal(last.cells["body"] == 1.0, state.cells.solid)
    grid_v = state.nodes.v[:, : last.velocity[..., 0].size].T.reshape(last.velocity.shape)
    assert last.velocity == pytest.approx(grid_v.astype(np.float32), rel=1e-7, abs=1e-30)
    soil = last.cells["volume_fraction"] > 0.99
    assert last.cells["su_pa"][soil] == pytest.approx(1e4, rel=1e-6)
    assert last.cells["mobilised_strength"][soil].max() == pytest.approx(1.0, rel=1e-5)
    figure = tmp_path / FIELD_PLOT_FILE
    longitudinal = figure.with_name(figure.stem + LONGITUDINAL_SUFFIX + figure.suffix)
    assert {figure, longitudinal} <= set(files)
    assert figure.stat().st_size > 10_000 and longitudinal.stat().st_size > 10_000


def test_3d_field_measures_of_known_states():
    """The 3D cell measures against closed forms: Tresca's (σ1 − σ3)/2 and √J2 of a principal state
    turned by a rotation; the hourglass amplitude of one pure hexahedral mode and of a linear field
    (0); the shear strain rate ε̇1 − ε̇3 of simple shear v_x = a·z (a)."""
    from dsmv.cel.kernels.elements3d import HOURGLASS, ROWS_3D, shear_strain_rates
    from dsmv.cel.layout import corner_offsets, structured_corners
    from dsmv.cel.state import Elastic, step_parameters
    from scipy.spatial.transform import Rotation

    principal = np.array([-30.0, 4.0, 10.0])
    turn = Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()
    sigma = turn @ np.diag(principal) @ turn.T
    q = np.zeros((ROWS_3D.base, 1, 1, 1))
    for name, (a, b) in {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1), "yz": (1, 2), "zx": (2, 0)}.items():
        q[ROWS_3D.of(name)] = sigma[a, b]
    su = np.full((1, 1, 1), 5.0)
    assert fields.mobilised_strength(q, su, tresca=True)[0, 0, 0] == pytest.approx(20.0 / 5.0, rel=1e-12)
    dev = principal - principal.mean()
    assert fields.mobilised_strength(q, su, tresca=False)[0, 0, 0] == pytest.approx(
        math.sqrt(0.5 * (dev**2).sum()) / 5.0, rel=1e-12)

    corner = structured_corners((1, 1, 1))
    v = np.zeros((3, 8))
    v[1, corner[0, 0, 0]] = 0.3 * HOURGLASS[2]  # the ξη vector in v_y, amplitude 0.3 m/s
    assert fields.hourglass_velocity(corner, v)[0, 0, 0] == pytest.approx(0.3, rel=1e-12)
    v[0, corner[0, 0, 0]] = 1.0  # a uniform v_x and a linear v_z add no hourglass
    v[2, corner[0, 0, 0]] = 2.0 * corner_offsets(3)[:, 0] - 0.5 * corner_offsets(3)[:, 2]
    assert fields.hourglass_velocity(corner, v)[0, 0, 0] == pytest.approx(0.3, rel=1e-12)

    from dsmv.cel.solver3d import faces_3d
    from dsmv.cel.layout import Cells, Nodes, Mesh3D, split_cells
    from dsmv.cel.kernels.elements3d import cell_volumes

    x, y, z = np.linspace(0.0, 1.0, 4), np.linspace(0.0, 0.5, 3), np.linspace(-1.0, 0.0, 5)
    shape = (3, 2, 4)
    corner = structured_corners(shape)
    mesh = Mesh3D(x, y, z, cell_volumes(x, y, z), corner, corner.max() + 1, split_cells(corner),
                     np.zeros(shape, dtype=np.uint8))
    solid = np.zeros(shape, bool)
    cells = Cells(np.ones(shape), np.zeros((ROWS_3D.base, *shape)), np.zeros(shape), np.ones(shape), solid,
                  np.ones(shape), np.zeros(shape), np.full(shape, np.nan), np.ones(shape))
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    nodes = Nodes(np.zeros((3, X.size)), np.zeros((3, X.size)), np.zeros(X.size), np.zeros((3, X.size)))
    a = 0.7
    nodes.v[0] = (a * Z).ravel()
    par = step_parameters(dt=1e-3, density=1.0, elastic=Elastic(1.0, 1.0, 1.0, 0.0), h=0.25, gravity=0.0, su0=1.0,
                          ks=0.0, hourglass=0.0, bulk_linear=0.0, bulk_quadratic=0.0, stress_cutoff=0.01,
                          axisymmetric=False, advection_order=2, drop=False, inflow=False, remap=True, tresca=True,
                          law_active=False)
    assert shear_strain_rates(mesh, cells, faces_3d(solid), nodes, par, 0.0) == pytest.approx(np.full(shape, a))
