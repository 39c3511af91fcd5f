"""What the CLI calls: garage, tracks, rewards, models and info.

Services validate their input completely before they write, do all writes of
one command in one transaction, and raise :class:`drx.errors.DrxError` with
one sentence for anything the user can fix. The CLI only parses and prints.
"""
