"""Remote control of a running pvcap session, from experiment software (docs/remote.md).

    from pvcap.remote import Remote
    r = Remote("http://127.0.0.1:8090", token_file="/etc/pvcap/token")
    r.status()["state"]                    # "recording"
    r.mark("stimulus_on", note="trial 3")  # committed to the session, on its clock
    r.command("next")                      # the protocol's commands, as the operator's keys
    r.stop("experiment over")              # the session ends as Ctrl-C ends it

It speaks the session's remote-control API, version 1 (/api/v1/...), over the session pages' own
server, with the session's token as a bearer token. Only the standard library: it runs in any Python
3 the experiment runs in. A refused request raises RemoteError with the session's message.
"""
import json
import urllib.error
import urllib.parse
import urllib.request

__all__ = ["Remote", "RemoteError", "API_VERSION"]

API_VERSION = 1


class RemoteError(RuntimeError):
    """A request the session refused or could not answer: `status` is the HTTP status (0: unreachable)."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status


class Remote:
    """A running session's remote control: `url` its pages' address (a path or query on it is ignored),
    the token given, or read from `token_file`'s first line."""

    def __init__(self, url, token=None, token_file=None, timeout=5.0):
        parts = urllib.parse.urlsplit(url)
        self.base = f"{parts.scheme}://{parts.netloc}/api/v{API_VERSION}"
        if token_file is not None:
            with open(token_file, encoding="utf-8") as f:
                token = f.readline().strip()
        self.token = token
        self.timeout = timeout

    def _request(self, method, route, fields=None):
        data = urllib.parse.urlencode(fields).encode() if fields is not None else None
        request = urllib.request.Request(self.base + route, data=data, method=method)
        if self.token:
            request.add_header("Authorization", f"Bearer {self.token}")
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as answer:
                return json.loads(answer.read().decode())
        except urllib.error.HTTPError as e:
            body = e.read().decode(errors="replace")
            try:
                message = json.loads(body).get("message", body)
            except ValueError:
                message = body.strip()
            raise RemoteError(e.code, f"{method} {route}: {e.code}: {message}") from None
        except urllib.error.URLError as e:
            raise RemoteError(0, f"{self.base}{route}: the session cannot be reached ({e.reason})") from None

    def status(self):
        """The session's state, folder, elapsed seconds, samples, streams and (with a protocol) its progress."""
        return self._request("GET", "/status")

    def mark(self, label, note=""):
        """Commits a mark (`label`, `note`) to the session on its clock; returns once it is stored."""
        return self._request("POST", "/mark", {"label": label, "note": note})

    def command(self, command, argument=""):
        """One of the protocol's commands (start, next, redo, skip, pause, bad, note, abort)."""
        return self._request("POST", "/command", {"command": command, "argument": argument})

    def stop(self, reason=""):
        """Stops the session (it closes its store and writes its report as after Ctrl-C)."""
        return self._request("POST", "/stop", {"reason": reason})
