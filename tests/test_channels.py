"""The relay channel map: one check (:func:`spherestep.channels.as_channel_map`) for design, plan and driver."""

import numpy as np
import pytest

from spherestep.channels import MAX_COILS, as_channel_map, default_channel_map
from spherestep.errors import InputError


def test_default_map_and_the_contract():
    cmap = default_channel_map(4)
    assert cmap.tolist() == [[0, 4], [1, 5], [2, 6], [3, 7]] and MAX_COILS == 32
    checked = as_channel_map(cmap, 4)
    assert np.array_equal(checked, cmap) and not checked.flags.writeable
    assert as_channel_map([[9, 3]]).tolist() == [[9, 3]]


@pytest.mark.parametrize("bad, count, words", [
    ([[0, 1]], 2, "2 pairs"), ([[0, 1], [1, 2]], 2, "distinct"), ([[0, -1]], None, "non-negative"),
    ([[0.5, 1]], None, "integer"), ([0, 1], None, "shape (2,)"), ([[0, 1, 2]], None, "shape (1, 3)"),
    ("ab", None, "pairs"),
])
def test_bad_maps_name_the_argument(bad, count, words):
    with pytest.raises(InputError) as err:
        as_channel_map(bad, count, name="plan.channel_map")
    assert err.value.field == "plan.channel_map" and words in str(err.value)
