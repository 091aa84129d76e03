"""``pfield param set`` against a real HTTP server: values are parsed as YAML, negative numbers included."""

from __future__ import annotations

from typer.testing import CliRunner

from pfield.cli import app
from pfield.node._base import Bus
from pfield.node.base_controller import BaseControllerNode
from pfield.transport.http import ServerThread, create_app


def test_param_set_takes_a_negative_value_like_ros2() -> None:
    node = BaseControllerNode(Bus())
    runner = CliRunner()
    with ServerThread(create_app([node])) as server:
        # the seed's "can go through" set has kr_dist -1; `ros2 param set` reads "-1" as the value
        result = runner.invoke(app, ["param", "set", "/base_controller", "kr_dist", "-1", "--url", server.url])
        assert result.exit_code == 0, result.output
        assert node.get_parameters()["kr_dist"] == -1.0
        after_dashes = runner.invoke(app, ["param", "set", "/base_controller", "kr_dist", "--url", server.url,
                                           "--", "-0.5"])
        assert after_dashes.exit_code == 0 and node.get_parameters()["kr_dist"] == -0.5
        bad = runner.invoke(app, ["param", "set", "/base_controller", "kr_slope", "-2.5", "--url", server.url])
        assert bad.exit_code == 2 and "kr_slope" in bad.output
        assert node.get_parameters()["kr_slope"] == 30.0  # refused: unchanged


def test_param_set_nan_is_refused_by_the_node_naming_the_parameter() -> None:
    node = BaseControllerNode(Bus())
    runner = CliRunner()
    with ServerThread(create_app([node])) as server:
        for value in (".nan", ".inf"):
            result = runner.invoke(app, ["param", "set", "/base_controller", "kr_slope", value, "--url", server.url])
            assert result.exit_code == 2, result.output
            assert "kr_slope" in result.output and "Traceback" not in result.output
    assert node.get_parameters()["kr_slope"] == 30.0


def test_param_set_an_absurd_value_is_refused_in_one_short_line_naming_the_parameter() -> None:
    """Issue 31 F3: a 400-digit integer was answered 500 (OverflowError); a 10 000-character frame was taken."""
    node = BaseControllerNode(Bus())
    before = node.get_parameters()
    runner = CliRunner()
    with ServerThread(create_app([node])) as server:
        for name, value in (("kr_slope", "1" * 400), ("kr_slope", "-" + "1" * 400), ("odom_frame", "o" * 10_000)):
            result = runner.invoke(app, ["param", "set", "/base_controller", name, value, "--url", server.url])
            assert result.exit_code == 2, result.output
            assert result.output.startswith(f"error: {name}=") and result.output.count("\n") == 1, result.output
            assert len(result.output) < 400 and "Traceback" not in result.output
    assert node.get_parameters() == before
