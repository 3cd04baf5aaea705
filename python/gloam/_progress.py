"""Progress reporting for long calls (``progress=`` of render, capture, sweep).

``progress=True`` shows a tqdm bar when tqdm is installed, else one line
on stderr per change; a callable is called as ``progress(done, total,
what)`` on the calling thread (``what``: ``"prepare: bvh"``, ``"tiles"``,
``"frames"``, ``"tasks"``; ``total`` 0 while preparing).
"""

import sys

__all__ = ["resolve", "finish"]


class _Bar:
    """``progress=True``: a tqdm bar, or plain lines without tqdm."""

    def __init__(self, desc):
        self.desc = desc
        self.bar = None
        try:
            from tqdm.auto import tqdm
        except ImportError:
            tqdm = None
        self._tqdm = tqdm
        self._last = None

    def __call__(self, done, total, what):
        """Shows ``done`` of ``total`` ``what``."""
        if self._tqdm is not None:
            if self.bar is None:
                self.bar = self._tqdm(total=total or None, desc=self.desc, unit=" " + what if total else "")
            if total and self.bar.total != total:
                self.bar.reset(total=total)
                self.bar.unit = " " + what
            self.bar.set_description(f"{self.desc} ({what})" if not total else self.desc, refresh=False)
            self.bar.n = done
            self.bar.refresh()
            return
        line = f"{self.desc}: {what} {done}/{total}" if total else f"{self.desc}: {what}"
        if line != self._last:
            print(line, file=sys.stderr, flush=True)
            self._last = line

    def close(self):
        """Closes the tqdm bar."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def resolve(progress, desc):
    """The callable a call reports to: None for ``None``/``False``, a bar
    for ``True``, else ``progress`` itself (which must be callable)."""
    if progress is None or progress is False:
        return None
    if progress is True:
        return _Bar(desc)
    if not callable(progress):
        raise TypeError("progress: expected True, False, None or a callable progress(done, total, what)")
    return progress


def finish(cb):
    """Closes what :func:`resolve` made (a user's callable is left alone)."""
    if isinstance(cb, _Bar):
        cb.close()
