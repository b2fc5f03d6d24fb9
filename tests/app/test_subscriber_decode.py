"""`wiithrow.app.network.subscriber.decode`: a payload that cannot be read as JSON is text."""

from wiithrow.app.network.subscriber import decode


def test_a_message_too_deep_to_read_is_text_not_a_recursion_error():
    """`decode` (Zenoh payloads): a nested payload is not JSON to its readers, like `garbage`."""

    nested = ("[" * 2000 + "]" * 2000).encode()
    assert decode(nested) == nested.decode()
    assert decode(b'{"schema": 1, "markers": []}') == {"schema": 1, "markers": []}
    assert decode(b"garbage") == "garbage"
