"""``make exits N=1000``: start, operate and SIGINT the node over and over; every exit must be clean."""
