"""The autonomy's command dP_r for the interactive task: the route navigator
(``navigator``), the model-predictive navigator (``mpc``, ``mpc_navigator``) with its
obstacle prediction (``obstacle_prediction``), route frame (``route_frame``) and a
distilled policy of it (``mpc_policy``), and the earliest passage along the route
among moving obstacles (``route_timing``). Every navigator offers the ``Navigator``
protocol (``protocol``)."""
