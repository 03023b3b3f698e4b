"""angles.png: a thermal run's fold angles over time, with the switch from heating to cooling."""

from PIL import Image

from dgplate.io.angle_chart import plot_angles, switch_time


def rows_of_a_box(switch_step: int = 3) -> list[dict]:
    """Heat steps (source +5) to the switch, its hold (same source), then cooling (−5)."""
    rows = []
    for step in range(1, 8):
        heating = step <= switch_step + 1
        rows.append(
            {"step": step, "time": 0.5 * min(step, switch_step) + 0.5 * max(0, step - switch_step - 1),
             "source": 5.0 if heating else -5.0, "angle_hinge_north": 30.0 * step,
             "angle_hinge_lid": 25.0 * step, "energy": 1.0}
        )  # fmt: skip
    return rows


def test_switch_is_the_last_time_before_the_source_changes_sign():
    rows = rows_of_a_box()
    assert switch_time(rows, "time") == 1.5  # the hold's row, at the switch's time
    assert switch_time(rows, "step") == 4
    assert switch_time([{"time": 1.0, "source": 5.0}, {"time": 2.0, "source": 5.0}], "time") is None
    assert switch_time([{"time": 1.0}, {"time": 2.0}], "time") is None
    through_zero = [{"time": 1.0, "source": 5.0}, {"time": 2.0, "source": 0.0},
                    {"time": 3.0, "source": -5.0}]  # fmt: skip
    assert switch_time(through_zero, "time") == 1.0


def test_angles_are_drawn_only_for_rows_with_fold_angles(tmp_path):
    assert plot_angles(rows_of_a_box(), tmp_path / "angles.png", "box")
    assert Image.open(tmp_path / "angles.png").size == (640, 380)  # 100 dpi × 6.4 × 3.8 in
    assert not plot_angles([{"step": 1, "time": 0.1, "energy": 1.0}], tmp_path / "none.png")
    assert not (tmp_path / "none.png").exists()
