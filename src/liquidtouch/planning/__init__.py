"""Planning a trial before the robot moves: the push that lets a target reach its ±.

``push`` weighs the container's slosh physics (the simulator's) and the property
model's reach along each push axis (:func:`plan_push`, ``run-trial --plan``). It sits
above both the lab path (``acquire``) and the simulator (``sim``), which must not
import each other.
"""

from liquidtouch.planning.push import PushPlan, plan_push

__all__ = ["PushPlan", "plan_push"]
