"""Shape quality of quads (core.quality): the fast split against its definition."""
import numpy as np

from core.quality import FaceState, accept_moves, best_split, quad_normals, triangle_quality


def _reference_split(nodes, quads):
    """best_split as first written: each triangle through triangle_quality."""
    p = nodes[quads]
    normal = quad_normals(nodes, quads)
    scores = []
    for first, second in (((0, 1, 2), (0, 2, 3)), ((1, 2, 3), (1, 3, 0))):
        worst = None
        for tri in (first, second):
            a, b, c = p[:, tri[0]], p[:, tri[1]], p[:, tri[2]]
            q = triangle_quality(a, b, c)
            q = np.where(np.einsum("ij,ij->i", np.cross(b - a, c - a), normal) > 0, q, 0.0)
            worst = q if worst is None else np.minimum(worst, q)
        scores.append(worst)
    use_second = scores[1] > scores[0]
    order = np.where(use_second[:, None], np.array([1, 2, 3, 1, 3, 0]), np.array([0, 1, 2, 0, 2, 3]))
    return np.take_along_axis(quads, order, axis=1).reshape(-1, 3), np.where(use_second, scores[1], scores[0])


def test_best_split_is_its_definition_to_the_last_bit():
    rng = np.random.default_rng(0)
    lattice = rng.normal(scale=0.2, size=(20_000, 3)) + rng.integers(0, 30, size=(20_000, 3))
    coarse = rng.integers(0, 3, size=(2_000, 3)).astype(float)  # flat, twisted and degenerate quads
    for nodes in (lattice, coarse):
        quads = rng.integers(0, len(nodes), size=(50_000, 4))
        triangles, quality = best_split(nodes, quads)
        expected_triangles, expected_quality = _reference_split(nodes, quads)
        assert np.array_equal(triangles, expected_triangles)
        assert np.array_equal(quality, expected_quality)


def test_a_face_state_handed_on_changes_nothing():
    rng = np.random.default_rng(1)
    nodes = rng.normal(scale=0.1, size=(3_000, 3)) + rng.integers(0, 12, size=(3_000, 3))
    quads = rng.integers(0, len(nodes), size=(6_000, 4))
    state = FaceState.unknown(len(quads))
    plain = with_state = nodes
    for _ in range(3):
        proposal = plain + rng.normal(scale=0.3, size=nodes.shape) * (rng.random((len(nodes), 1)) < 0.5)
        plain, kept = accept_moves(plain, proposal, quads, 0.2)
        given_up = proposal.copy()
        with_state, kept_too = accept_moves(with_state, given_up, quads, 0.2, state=state, overwrite_new=True)
        assert with_state is given_up  # the moves undone in the caller's array
        assert np.array_equal(plain, with_state) and np.array_equal(kept, kept_too)


def test_split_along_gives_each_quads_two_triangles_in_blocks(monkeypatch):
    """100 k quads (blocks of rows on three threads): quad m's triangles are
    rows 2m and 2m + 1, (0, 1, 2) and (0, 2, 3) or (1, 2, 3) and (1, 3, 0)."""
    from core.quality import split_along

    monkeypatch.setenv("URBANVOX_THREADS", "3")
    rng = np.random.default_rng(8)
    quads = rng.integers(0, 10**6, (100_003, 4)).astype(np.int32)
    use_second = rng.random(len(quads)) < 0.5
    triangles = split_along(quads, use_second, dtype=np.int64)
    first = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1)
    second = np.concatenate([quads[:, [1, 2, 3]], quads[:, [1, 3, 0]]], axis=1)
    wanted = np.where(use_second[:, None], second, first).reshape(-1, 3)
    assert triangles.dtype == np.int64 and np.array_equal(triangles, wanted)
