"""Drive fields at other friction and the friction-aware teacher over them
(mdr_drive_agents.teacher.friction)."""

import numpy as np
import pytest

from mdr_drive_agents.teacher import DriveField, FieldConfig, FrictionField
from mdr_drive_agents.train.friction_teacher import FrictionTeacherConfig
from tests.agents.fields import friction_field as _field


def test_a_field_searched_at_other_friction_plays_its_nodes_there_and_reads_loads_over_mu():
    field = _field(0.15)
    assert field.friction == (0.3, 0.15) and field.point(1, 2) == (0.3, pytest.approx(0.06), 0.3, 0.15)
    assert field.with_friction([(0.1, 0.02)]) == [(0.1, 0.02, 0.3, 0.15)]
    assert field.field_load((0.1, 0.02, 0.2, 0.1)) == pytest.approx(0.03)  # the same load over mu F_ref
    assert _field(0.1).friction == (0.3, 0.1) == DriveField(*[getattr(field, a) for a in (
        "ks", "fractions", "trapezoid_critical", "drives", "velocities")]).friction  # no config: the paper's
    with pytest.raises(ValueError, match="friction mu"):
        FieldConfig(friction=(0.0, 0.1))
    with pytest.raises(ValueError, match="friction"):
        FieldConfig(friction=(0.3,))


def test_the_friction_field_mixes_the_two_fields_around_the_points_ratio():
    low, high = _field(0.06, fill=0.2), _field(0.12, fill=0.6)  # rho 0.2 and 0.4
    ff = FrictionField([high, low])
    assert ff.rhos.tolist() == pytest.approx([0.2, 0.4])  # sorted by rho
    cands = ff.candidates((0.15, 0.01, 0.3, 0.09), radius=1)  # rho 0.3: halfway
    assert len(cands) == 1 + 5 + 5 and cands[0] == pytest.approx(np.full((2, 5), 0.4))
    assert ff.candidates((0.15, 0.01, 0.3, 0.03))[0] == pytest.approx(np.full((2, 5), 0.2))  # below the range: clipped
    drives, v = ff.best([(0.15, 0.01, 0.25, 0.075), (0.1, 0.0)])
    assert drives.shape == (2, 2, 5) and v.shape == (2,) and np.isfinite(v).all()
    own = ff.candidates((0.15, 0.01, 0.3, 0.09), radius=1, interpolation=False)  # the two fields' grid drives only
    assert len(own) == 4 + 4 and set(np.round(own, 6).ravel()) == {0.2, 0.6}
    drives, v = ff.best([(0.15, 0.01, 0.3, 0.09)], interpolation=False)
    assert set(np.round(drives, 6).ravel()) <= {0.2, 0.6} and np.isfinite(v).all()
    from mdr_drive_agents.student.data import grid_actions

    table = grid_actions(ff)  # a codebook student of a friction teacher picks among every field's drives
    np.testing.assert_array_equal(table, np.concatenate([grid_actions(low), grid_actions(high)]))
    with pytest.raises(ValueError, match="ratio"):
        FrictionField([low, _field(0.06)])
    with pytest.raises(ValueError, match="k grid"):
        FrictionField([low, _field(0.12, ks=(0.0, 0.6))])
    with pytest.raises(ValueError, match="rhos"):
        FrictionTeacherConfig(rhos=(0.0,))
    with pytest.raises(ValueError, match="base_friction_coefficient"):
        FrictionTeacherConfig(base_friction_coefficient=(0.2, 0.1))
