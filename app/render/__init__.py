"""The deferred pipeline: G-buffer pass -> lighting pass -> post, each its own module."""
