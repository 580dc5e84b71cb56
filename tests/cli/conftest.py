"""The learning tests' fixtures (blob images, an isolated weights and feature cache), for command-line tests."""

from tests.learn.conftest import blobs, learn_cache  # noqa: F401
