"""The robot's body supervision, pure: the checks as data, the readings they take, their evaluation."""
