"""The flight recorder's pure side: what it keeps (events.py), the bounded ring that keeps it (ring.py), and how
its incident files are named, found and rotated (incidents.py)."""
