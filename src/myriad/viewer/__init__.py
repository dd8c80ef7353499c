"""Watching envs live in a browser: `myriad.viewer.serve(envs)` (`web.Viewer`), drawing the
model's geoms (`shapes`). Needs the `viewer` extra (viser)."""

from .web import Viewer, require_viser, serve

__all__ = ["Viewer", "require_viser", "serve"]
