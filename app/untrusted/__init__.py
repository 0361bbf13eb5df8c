"""Every file and value a user hands pbs is untrusted; this package is where that is dealt
with once, for every format (docs/stability.md, "Untrusted input").

- ``policy``: which folders a file's references may reach (``InputPolicy``) and the limits
  that bound what reading them may cost (``Limits``).
- ``files``: the one way an input file is opened: confined to the allowed folders
  (symlinks resolved first), special files (FIFOs, devices, folders) refused before they
  are opened, sizes checked before a byte is read; and the outputs that must not replace
  an input.
- ``budget``: the memory an input will take, added up from the sizes its headers declare
  before anything of that size is allocated (``Budget``).
- ``structured``: JSON and TOML parsed with their nesting bounded and non-finite numbers
  refused.

A refusal is a ``RefusedError`` carrying one sentence that says nothing about a file outside
the allowed folders (not its size, bytes or existence); the caller adds the file and key
it belongs to (an ``InputError``, or a glTF reader's ``GltfError``).
"""

from __future__ import annotations


class RefusedError(ValueError):
    """Input that pbs will not read: the message is one sentence, safe to show."""
