"""Typed scene values: what a randomiser draws, as frozen records that check themselves when
made and read back from a sample's stored JSON (``from_json``) exactly as they were written
(``to_json``). The worlds realise them into SAPIEN things and the USD export into prims, each by
the value's type, so a value type without a realiser fails loudly in both."""
