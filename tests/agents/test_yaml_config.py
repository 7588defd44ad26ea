"""The one config reader (mdr_drive_agents.yaml_config): YAML mappings into typed, validated dataclasses."""

import pytest

from mdr_drive_agents.teacher.config import FieldConfig, PolishPass, PolishStall
from mdr_drive_agents.train.recipe import DEFAULT_CONFIG, RecipeConfig, load_recipe
from mdr_drive_agents.yaml_config import build, read_yaml


def test_nested_stages_are_built_as_their_dataclasses_and_lists_as_tuples():
    config = build(FieldConfig, {"k_range": [0.0, 0.3], "polish": [{"budget": 8, "sigma": 0.1}],
                                 "polish_stall": {"budget": 8, "sigma": 0.1, "k_max": 0.15}}, "teacher")
    assert config.k_range == (0.0, 0.3) and config.polish == (PolishPass(8, 0.1),)
    assert config.polish_stall == PolishStall(8, 0.1, 0.15) and config.stages() == [PolishStall(8, 0.1, 0.15)]


@pytest.mark.parametrize("data, needle", [
    ({"k_valus": 3}, r"teacher: unknown key\(s\) \['k_valus'\]"),
    ({"polish_stall": [1500, 0.3, 0.15]}, r"teacher.polish_stall: \[1500, 0.3, 0.15\] must be a mapping of budget, sigma, k_max"),
    ({"polish": {"budget": 8, "sigma": 0.1}}, "teacher.polish: .* must be a list of mappings"),
    ({"polish_stall": {"budget": 0, "sigma": 0.1}}, "teacher.polish_stall: polish_stall budget=0"),
    ({"polish_stall": {"budget": 8}}, r"teacher.polish_stall: missing key\(s\) \['sigma'\]"),
    ({"k_values": 1}, "teacher: k_values=1 is outside the allowed range"),
])
def test_a_bad_config_is_one_error_naming_the_key(data, needle):
    with pytest.raises(ValueError, match=needle):
        build(FieldConfig, data, "teacher")


def test_the_shipped_recipe_reads_and_a_broken_file_is_one_line(tmp_path):
    recipe = load_recipe(DEFAULT_CONFIG)
    assert isinstance(recipe, RecipeConfig) and recipe.seeds == (0, 1) and recipe.distill.action_codebook
    assert recipe.student == "distill" and recipe.worth.arch == (512, 512, 512)  # --student worth builds the other
    sensor = recipe.sensor_policy  # the sensor policy from the teacher's drives, its table's searches from them
    assert sensor.table.polish_from is None and sensor.sensor.sensor_tier == "trace"
    (tmp_path / "bad.yaml").write_text("seed: [unclosed")
    with pytest.raises(ValueError, match="not valid YAML"):
        read_yaml(tmp_path / "bad.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(ValueError, match="a config file is a mapping"):
        read_yaml(tmp_path / "list.yaml")
    with pytest.raises(ValueError, match="cannot be read"):
        read_yaml(tmp_path / "missing.yaml")
