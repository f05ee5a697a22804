"""Each solver value out of its range is refused once, by SolverSettings where it is constructed, with the same
one-line message through the API (``ContactProblem(..., settings={...})``), the command line's flag and a
scene's ``[solver]`` key (exit 2 on every rank, before anything is built); on 1 and 2 ranks."""

from __future__ import annotations

import dataclasses

from mpi4py import MPI

import pytest

from fenics_coulomb import ContactProblem, InputError, SolverSettings
from fenics_coulomb.cli import build_parser, main
from fenics_coulomb.scenes.scene import FLAGS, KINDS, Scene
from fenics_coulomb.settings import GAMMA_SCALE_RANGE, INTEGER_BOUNDS

#: (setting, value out of its range) — every range rule of SolverSettings, at and beyond each bound.
CASES = [
    ("tol", 0.0), ("tol", 1.0), ("rtol", 0.0), ("rtol", 1.5), ("accuracy", 1e-14), ("accuracy", 1.0),
    ("gamma_scale", 0.0), ("gamma_scale", GAMMA_SCALE_RANGE[0] / 2), ("gamma_scale", GAMMA_SCALE_RANGE[1] * 2),
    ("gamma_scale", 1e9), ("gamma_scale", float("nan")), ("gamma", 0.0), ("gamma", -1.0),
    ("gamma_node_scale", 0.0), ("gamma_node_scale", 1e-300), ("gamma_node_scale", GAMMA_SCALE_RANGE[1] * 2),
    ("poisson_ratio", 0.5), ("poisson_ratio", -1.0),
    *[(name, 0) for name in INTEGER_BOUNDS], *[(name, bound + 1) for name, bound in INTEGER_BOUNDS.items()],
    ("variant", "4c"), ("pc", "multigrid"),
]
#: The command line's flag of each setting that has one (the flag's destination is the setting's name).
FLAG = {action.dest: action.option_strings[0] for action in build_parser()._actions
        if action.option_strings and FLAGS.get(action.dest, (None,))[0] == "solver"}


def message(setting: str, value: object) -> str:
    """SolverSettings' own refusal of the value."""
    with pytest.raises(InputError) as err:
        SolverSettings(**{setting: value})
    return str(err.value)


@pytest.mark.parametrize("setting, value", CASES, ids=[f"{s}={v}" for s, v in CASES])
def test_api_and_command_line_refuse_with_the_same_message(setting, value, mpi_tmp_path, capsys):
    expected = message(setting, value)
    assert expected.startswith((f"{setting} = ", "variant ", "preconditioner ")), expected
    assert "\n" not in expected
    # the API: the settings are checked before anything collective (no forms are needed to be refused)
    with pytest.raises(InputError) as err:
        ContactProblem(None, None, bcs=[], settings={setting: value}, petsc_options_prefix="refuse_")
    assert str(err.value) == expected
    # the scene's [solver] table, as the command line reads it
    scene = mpi_tmp_path / "scene.toml"
    if MPI.COMM_WORLD.rank == 0:
        text = f'"{value}"' if isinstance(value, str) else repr(value)  # TOML: 1e-14, nan, 0
        scene.write_text(f"[body]\nlev = 0\n\n[solver]\n{setting} = {text}\n")
    MPI.COMM_WORLD.barrier()
    capsys.readouterr()
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "out"), "--no-plots"]) == 2
    captured = capsys.readouterr()
    # (a non-finite number is a kind error, found where the file is read and named with its table)
    where = "[solver] " if isinstance(value, float) and value != value else ""
    if MPI.COMM_WORLD.rank == 0:
        assert captured.err.strip().endswith(f"error: {where}{expected}"), captured.err
    # the flag, where the command line has one
    if setting in FLAG:
        assert main(["--lev", "0", FLAG[setting], str(value), "--out", str(mpi_tmp_path / "out"), "--no-plots"]) == 2
        captured = capsys.readouterr()
        if MPI.COMM_WORLD.rank == 0:
            assert captured.err.strip().endswith(f"error: {expected}"), captured.err


def test_the_flags_cover_the_ranges():
    """The command-line flags reached by the cases above (the others are scene keys and API fields only)."""
    assert {"tol", "rtol", "accuracy", "gamma_scale", "max_it", "variant", "pc"} <= set(FLAG)


def test_the_scene_kinds_are_the_settings_fields():
    """[solver] accepts exactly the fields of SolverSettings (matrix_free was missing from a restated table)."""
    assert set(KINDS["solver"]) == {f.name for f in dataclasses.fields(SolverSettings)}
    assert KINDS["solver"]["matrix_free"] == "bool"


def test_settings_are_valid_wherever_they_exist():
    """A SolverSettings cannot be changed into an invalid one after its construction: it is frozen, and
    dataclasses.replace constructs (and so validates) a new one."""
    settings = SolverSettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.gamma_scale = 1e9  # type: ignore[misc]
    with pytest.raises(InputError, match="gamma_scale"):
        dataclasses.replace(settings, gamma_scale=1e9)
    assert Scene().override(gamma_scale=2.0).solver.gamma_scale == 2.0


def _scene_refusal(mpi_tmp_path, capsys, text: str) -> str:
    """The one error line of the command line on the scene ``text`` (exit 2; rank 0's, '' elsewhere)."""
    scene = mpi_tmp_path / "scene.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text(text)
    MPI.COMM_WORLD.barrier()
    capsys.readouterr()
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "out"), "--no-plots", "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    if MPI.COMM_WORLD.rank != 0:
        assert lines == []
        return ""
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize("gamma", [1e300, 1e-300])
def test_a_fixed_gamma_far_from_the_stiffness_is_refused(gamma, mpi_tmp_path, capsys):
    """γ = 1e300 overflowed the residual's norm (a traceback, exit 1), γ = 1e-300 exited 3 blaming the mesh: a
    fixed γ must lie within GAMMA_SCALE_RANGE × λ_max(A), like gamma_scale."""
    line = _scene_refusal(mpi_tmp_path, capsys, f"[body]\nlev = 1\n[solver]\ngamma = {gamma!r}\n")
    if MPI.COMM_WORLD.rank == 0:
        assert f"error: gamma = {gamma:g}: must lie in [1e-06, 1e+06] x lambda_max(A)" in line, line


def test_rtol_and_accuracy_together_are_refused_alike(mpi_tmp_path, capsys):
    """The scene refused rtol and accuracy together, the API took both (accuracy won): one message now."""
    with pytest.raises(InputError) as err:
        SolverSettings(rtol=1e-6, accuracy=1e-4)
    line = _scene_refusal(mpi_tmp_path, capsys, "[body]\nlev = 1\n[solver]\nrtol = 1e-6\naccuracy = 1e-4\n")
    if MPI.COMM_WORLD.rank == 0:
        assert line.endswith(f"error: {err.value}"), (line, str(err.value))
    # a flag replaces the scene's other one (no refusal): the reduction is the flag's
    path = mpi_tmp_path / "rtol.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text("[body]\nlev = 1\n[solver]\nrtol = 1e-6\n")
    MPI.COMM_WORLD.barrier()
    flagged = Scene.from_toml(path).override(accuracy=1e-4)
    assert flagged.solver.accuracy == 1e-4 and flagged.solver.rtol == SolverSettings().rtol
    assert "rtol" not in flagged.given and "accuracy" in flagged.given
    again = flagged.override(rtol=1e-9)
    assert again.solver.accuracy is None and again.solver.rtol == 1e-9 and "accuracy" not in again.given


def test_the_sliding_model_is_refused_alike(mpi_tmp_path, capsys):
    """The API said ['finite', 'small'], the scene finite, small: one message."""
    from fenics_coulomb.model.arguments import check_sliding

    with pytest.raises(InputError) as err:
        check_sliding("Large")
    line = _scene_refusal(mpi_tmp_path, capsys, '[body]\nlev = 1\n[contact]\nsliding = "Large"\n')
    if MPI.COMM_WORLD.rank == 0:
        assert line.endswith(f"error: {err.value}"), (line, str(err.value))


def test_a_rotation_angle_must_be_a_number(mpi_tmp_path, capsys):
    """A string angle ("  1e1 ") was read as 10 degrees (exit 0)."""
    from fenics_coulomb import Sphere

    with pytest.raises(InputError, match="the angle must be a number"):
        Sphere(center=[1.0, 0.5, 1.5], radius=0.3, rotation=["10", [0.0, 1.0, 0.0], [1.0, 0.5, 1.5]])
    line = _scene_refusal(mpi_tmp_path, capsys, '[body]\nlev = 1\n[[obstacle]]\ntype = "sphere"\n'
                          'center = [1.0, 0.5, 1.5]\nradius = 0.3\nrotation = ["  1e1 ", [0.0, 1.0, 0.0], '
                          '[1.0, 0.5, 1.5]]\n')
    if MPI.COMM_WORLD.rank == 0:
        assert "the angle must be a number" in line, line
