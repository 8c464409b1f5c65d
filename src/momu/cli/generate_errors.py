"""The error every ``momu generate`` check raises (re-exported by :mod:`momu.cli.generate_io`)."""

from __future__ import annotations

__all__ = ["GenerateInputError", "GenerateOutputError"]


class GenerateInputError(ValueError):
    """A bad input, output path or model folder of ``momu generate`` (one line, exit status 2)."""


class GenerateOutputError(OSError):
    """Writing the outputs failed after the work was done (a full disk): one line, exit status 1.

    Nothing is left half-written: the outputs are written to temporaries beside their final names and
    moved into place together only when every one is complete (:class:`momu.cli.output_paths.StagedOutputs`).
    """
