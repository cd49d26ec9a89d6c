"""gbpipe.memo: the bounded memo tables of repeated array computations."""

import numpy as np
import pytest

from gbpipe.memo import ArrayMemo, array_key


def test_a_repeat_is_not_recomputed_and_the_oldest_result_goes_first():
    calls = []
    memo = ArrayMemo(2)

    def square(x):
        calls.append(x)
        return x * x

    assert [memo(k, lambda k=k: square(k)) for k in (1, 2, 1, 3, 1, 2)] == [1, 4, 1, 9, 1, 4]
    # 1 and 2 computed; 1 again remembered; 3 drops 2 (least recently used); 1 remembered;
    # 2 computed again
    assert calls == [1, 2, 3, 2]
    assert len(memo) == 2


def test_remembered_arrays_are_read_only():
    memo = ArrayMemo(1)
    a, b = memo("k", lambda: (np.zeros(3), np.ones(2)))
    with pytest.raises(ValueError, match="read-only"):
        a[0] = 1.0
    assert memo("k", lambda: None)[1] is b


def test_keys_differ_with_dtype_shape_or_bytes_and_agree_for_copies():
    x = np.arange(6.0)
    assert array_key(x) == array_key(x.copy())
    assert array_key(x[::2]) == array_key(np.array([0.0, 2.0, 4.0]))  # strided: by value
    assert array_key(x) != array_key(x.reshape(2, 3))
    assert array_key(x) != array_key(x.astype(np.float32))
    y = x.copy()
    y[5] = np.nextafter(5.0, 6.0)
    assert array_key(x) != array_key(y)


def test_size_must_be_positive():
    with pytest.raises(ValueError, match="size must be > 0"):
        ArrayMemo(0)
