"""Control on snapo_ode: classic control problems with published baselines, trained by
backpropagation through their rollouts. Named `snapo_control`, so that it installs beside
python-control (import name `control`). `snapo_control.pendulum`: Gymnasium's Pendulum-v1, whose
angle is a periodic state component (`snapo_ode.Periodic`). See docs/pendulum.md."""
