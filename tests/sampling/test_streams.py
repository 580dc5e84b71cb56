"""The named random streams: each draws what its seed list drew before the registry, names and tails are unique."""

import pytest

from deformsim.sampling import streams as sampling_streams
from deformsim.sampling.features import FEATURES, STREAMS
from deformsim.sampling.streams import generator, stable_int, stream

SEED, INDEX, IMAGE = 7, 3, "000003_c1"
# The first uniform of each stream for SEED, sample INDEX and image IMAGE, frozen from the hand-numbered seed lists
# (default_rng([seed, index, 1..5]), default_rng([seed, stable_int(id), 0xF11F]), ...) the streams replace, and for
# the streams added since, from their first release (shape, appearance, regions, print, sun).
FIRST = {
    "sample": 0.9750335537195014,
    "source": 0.5324211967452813,
    "drop": 0.8116590994374309,
    "lights": 0.6916198486052162,
    "surface": 0.13177165895403264,
    "framing": 0.04910157400821569,
    "shape": 0.012844198808287799,
    "appearance": 0.40663309299524075,
    "regions": 0.2867348686972654,
    "print": 0.825905643333741,
    "sun": 0.5388613156610552,
    "image": 0.7726612477369958,
    "flip": 0.23443016294682661,
    "shadow": 0.45526413157163215,
    "scene": 0.692219313511429,
    "balance": 0.5761914198141822,
}
KEYS = {"index": INDEX, "image": stable_int(IMAGE)}


def test_image_ids_key_their_streams_by_a_stable_64_bit_integer():
    assert stable_int(IMAGE) == 15176047310193502465


@pytest.mark.parametrize("name", sorted(FIRST))
def test_each_stream_draws_what_it_drew_before(name):
    keys = [KEYS[k] for k in STREAMS[name].keys]
    assert generator(STREAMS[name], SEED, *keys).uniform() == FIRST[name]


def test_every_stream_is_frozen_draws_numbers_of_its_own_and_says_what_it_is_for():
    assert set(STREAMS) == set(FIRST)  # a new stream has its first draw frozen above
    declared = [f.name for f in FEATURES if f.stream is not None]
    assert len(STREAMS) == len(sampling_streams.STREAMS) + len(declared)  # no feature's stream hides another's name
    draws = {tuple(generator(s, SEED, *[KEYS[k] for k in s.keys]).random(4)) for s in STREAMS.values()}
    assert len(draws) == len({(s.keys, s.tail) for s in STREAMS.values()}) == len(STREAMS)  # no two draw alike
    assert all(set(s.keys) <= set(KEYS) and s.purpose for s in STREAMS.values())


def test_a_stream_takes_exactly_its_keys():
    with pytest.raises(TypeError, match="takes 1 key"):
        stream("flip", SEED)
    with pytest.raises(TypeError, match="takes 0 key"):
        stream("balance", SEED, INDEX)
    with pytest.raises(KeyError):
        stream("nope", SEED, INDEX)
