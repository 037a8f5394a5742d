"""Definitions of the G1's Unitree SDK2 protocol, shared by the node's SDK adapter and the sim bridge.

Nothing here talks to a robot: these are names, numbers and message types, each defined once.
"""
