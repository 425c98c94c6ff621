"""Every test under tests/problems runs without network: fronts must be computed offline."""

import socket
import urllib.request

import pytest
from pymoo.util.remote import Remote


class NetworkAccess(AssertionError):
    """Raised by the guard below when anything tries to reach the network."""


def _refuse(*args, **kwargs):
    raise NetworkAccess("network access attempted")


@pytest.fixture(autouse=True)
def no_network(monkeypatch):
    monkeypatch.setattr(socket.socket, "connect", _refuse)
    monkeypatch.setattr(socket, "create_connection", _refuse)
    monkeypatch.setattr(urllib.request, "urlopen", _refuse)
    monkeypatch.setattr(Remote, "load", _refuse)
