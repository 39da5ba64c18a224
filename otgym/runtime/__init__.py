"""The interactive runtime: the one control tick (``tick``), batched trials of
simulated participants (``trials``), the real-time loop for one environment with real
devices (``loop``), a person's session of trials paced by the wall clock
(``session``), the session in a process of its own (``worker``), and the interfaces
they offer (``protocols``)."""
