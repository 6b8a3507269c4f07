"""Dialect options of the Sinumerik and Heidenhain posts: machine file, CLI, refusals."""

from __future__ import annotations

from pathlib import Path

import pytest

from cam.cli import main
from impeller_cam.errors import InputError
from postproc.command import post_text
from postproc.machine import load_machine
from tests.postproc.golden.cases import APT, SIM

Capture = pytest.CaptureFixture[str]


def machine_with_control(tmp_path: Path, control: str) -> Path:
    """The sim machine file with a ``[control]`` table appended."""
    path = tmp_path / "machine.toml"
    text = SIM.read_text().replace('post = "linuxcnc"\n', "")
    path.write_text(text + "\n" + control)
    return path


@pytest.mark.parametrize("post", ["sinumerik", "heidenhain"])
def test_vectors_without_tcp_are_refused_with_exit_2(post: str, tmp_path: Path,
                                                     capsys: Capture) -> None:
    out = tmp_path / "program.nc"
    code = main(["post", str(APT), "-m", str(SIM), "-o", str(out), "--post", post,
                 "--post-option", "orientation=vector"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "orientation" in err and "--tcp" in err
    assert ("TRAORI" in err) == (post == "sinumerik")
    assert ("TCPM" in err) == (post == "heidenhain")


def test_unknown_option_names_the_nearest(tmp_path: Path, capsys: Capture) -> None:
    out = tmp_path / "p.mpf"
    assert main(["post", str(APT), "-m", str(SIM), "-o", str(out), "--post", "sinumerik",
                 "--post-option", "orientaton=vector"]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'orientation'" in err and not out.exists()
    assert main(["post", str(APT), "-m", str(SIM), "-o", str(out), "--post", "sinumerik",
                 "--post-option", "feed=per-tooth"]) == 2
    assert "inverse-time, path" in capsys.readouterr().err
    assert main(["post", str(APT), "-m", str(SIM), "-o", str(out), "--post", "heidenhain",
                 "--post-option", "tcpm"]) == 2
    assert "KEY=VALUE" in capsys.readouterr().err


def test_options_of_another_dialect_are_refused() -> None:
    with pytest.raises(InputError, match="has no option 'tcpm'") as error:
        post_text(APT, SIM, post="sinumerik", tcp=True, post_options={"tcpm": "m128"})
    assert "cycle832" in str(error.value)  # lists what the dialect accepts


def test_machine_file_names_the_control_and_its_options(tmp_path: Path) -> None:
    path = machine_with_control(tmp_path, '[control]\ndialect = "sinumerik"\n'
                                'model = "SINUMERIK 840D sl"\n'
                                '[control.options]\norientation = "vector"\ncycle832 = false\n')
    machine = load_machine(path)
    assert machine.post == "sinumerik" and machine.control_model == "SINUMERIK 840D sl"
    text = post_text(APT, path, tcp=True)
    assert "A3=" in text and "ORIVECT" in text and "CYCLE832" not in text
    # the command line wins over the machine file
    text = post_text(APT, path, tcp=True, post_options={"orientation": "rotary"})
    assert "A3=" not in text and "A=" in text
    # the machine's options belong to its dialect: another dialect ignores them
    assert "M428" in post_text(APT, path, tcp=True, post="linuxcnc")
    # vectors from the machine file without TCP: refused, naming the machine file
    with pytest.raises(InputError, match="TRAORI") as error:
        post_text(APT, path)
    assert error.value.file is not None and Path(error.value.file) == path


def test_machine_file_control_errors(tmp_path: Path) -> None:
    path = machine_with_control(tmp_path, '[control]\ndialect = "heidenhain"\n'
                                '[control.options]\ntcmp = "m128"\n')
    with pytest.raises(InputError, match="did you mean 'tcpm'") as error:
        load_machine(path)  # checked when the machine is read (impeller-cam check too)
    assert error.value.field == "control.options.tcmp"
    assert error.value.file is not None and Path(error.value.file) == path
    clash = tmp_path / "clash.toml"
    clash.write_text(SIM.read_text() + '\n[control]\ndialect = "heidenhain"\n')
    with pytest.raises(InputError, match="different dialects"):
        load_machine(clash)


def test_posts_lists_each_dialect_with_its_options(capsys: Capture) -> None:
    assert main(["posts"]) == 0
    out = capsys.readouterr().out
    for name in ("sinumerik", "heidenhain", "linuxcnc", "fanuc"):
        assert f"\n{name} " in out
    for option in ("orientation=rotary|vector", "feed=inverse-time|path",
                   "cycle832=on|off", "tcpm=function|m128", "cycl32=on|off"):
        assert f"--post-option {option}" in out


def test_m128_and_path_feed_forms(tmp_path: Path) -> None:
    text = post_text(APT, SIM, post="heidenhain", tcp=True, post_options={"tcpm": "m128"})
    assert "L M128" in text and "L M129" in text and "TCPM" not in text
    text = post_text(APT, SIM, post="sinumerik", tcp=True, post_options={"feed": "path"})
    assert "G93" not in text and "TRAORI" in text


@pytest.mark.parametrize("post", ["sinumerik", "heidenhain"])
def test_comments_are_sanitised(post: str) -> None:
    from postproc.apt import read_apt
    from postproc.posting import post_toolpaths
    from postproc.posts import PostOptions, get_post

    evil = "op\nG0 X999 ; M30 (MSG, stop) %_N_X_MPF \u00e9"
    toolpaths = read_apt(APT)
    toolpaths[0].name = evil
    options = PostOptions(header=(evil,), footer=("end\rM30",))
    text = get_post(post).write(post_toolpaths(toolpaths, load_machine(SIM), options), options)
    comments = [line for line in text.splitlines() if "; " in line]
    assert sum("op G0 X999" in line for line in comments) == 2  # header and operation
    for line in comments:
        body = line.split("; ", 1)[1]
        assert ";" not in body and "(" not in body and "%" not in body
        assert all(32 <= ord(c) <= 126 for c in body)
    for line in text.splitlines():  # the injected block stays inside a comment
        if "X999" in line:
            assert "; " in line.split("X999")[0]
    code = [line.split(";", 1)[0] for line in text.splitlines()]
    assert sum("M30" in part for part in code) == 1  # the program's own end only
