"""`rangemesh.blocks`: NumPy's steps a block at a time give NumPy's results, element for element."""

import numpy as np
import pytest

from rangemesh import blocks
from rangemesh.blocks import BLOCK


@pytest.mark.parametrize("n, per", [(0, 1), (5, 1), (BLOCK, 1), (BLOCK + 1, 1), (3 * BLOCK, 3),
                                    (7, 2 * BLOCK)])
def test_blocks_cover_the_range_once_in_order(n, per):
    got = list(blocks.blocks(n, per))
    assert got[0].start == 0 and got[-1].stop == n
    assert all(a.stop == b.start for a, b in zip(got, got[1:], strict=False))
    assert all(s.stop - s.start <= max(BLOCK // per, 1) for s in got)


@pytest.fixture
def big():
    # more than one block of rows (the 3 columns count)
    return np.random.default_rng(3).integers(-9, 2**40, size=(BLOCK // 3 + 17, 3))


def test_astype_take_concat_and_filled_are_numpys(big):
    assert np.array_equal(blocks.astype(big, np.float32), big.astype(np.float32))
    index = np.random.default_rng(4).integers(0, len(big), size=BLOCK + 5)
    assert np.array_equal(blocks.take(big, index), big[index])
    assert np.array_equal(blocks.take(big[:, 0], index), big[index, 0])
    parts = [big, big[:5], big[::-1].astype(np.int32)]
    want = np.concatenate(parts)
    got = blocks.concat(parts)
    assert got.dtype == want.dtype and np.array_equal(got, want)
    for shape in [(3, 4), (BLOCK // 100 + 1, 100)]:
        got = blocks.filled(shape, np.nan)
        assert got.shape == shape and np.isnan(got).all()
        assert np.array_equal(blocks.filled(shape, -1, np.int64), np.full(shape, -1, np.int64))
