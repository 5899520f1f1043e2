# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A client of the node that knows only the ``simulation_interfaces`` types."""

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import Result, SimulationState
from simulation_interfaces.srv import (
    GetEntities, GetEntitiesStates, GetEntityState, GetSimulationState, GetSimulatorFeatures,
    ResetSimulation, SetEntityState, SetSimulationState, StepSimulation)

SERVICES = {'get_simulator_features': GetSimulatorFeatures,
            'get_simulation_state': GetSimulationState,
            'set_simulation_state': SetSimulationState, 'step_simulation': StepSimulation,
            'reset_simulation': ResetSimulation, 'get_entities': GetEntities,
            'get_entity_state': GetEntityState, 'get_entities_states': GetEntitiesStates,
            'set_entity_state': SetEntityState}


class Client:
    """A simulation_interfaces client in its own context; every wait has a deadline."""

    def __init__(self, namespace='/cfem'):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node('sim_client', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clients = {name: self.node.create_client(kind, f'{namespace}/{name}')
                        for name, kind in SERVICES.items()}
        self.action = ActionClient(self.node, SimulateSteps, f'{namespace}/simulate_steps')

    def ready(self, node, timeout=120.0):
        """Wait for the node's services and action (fail at once if the node ended)."""
        waiting = list(self.clients.values()) + [self.action]
        for _ in range(int(timeout)):
            waiting = [c for c in waiting if not (
                c.server_is_ready() if c is self.action else c.service_is_ready())]
            if not waiting:
                return
            assert node.alive(), node.output
            self.executor.spin_once(timeout_sec=1.0)
        raise AssertionError(f'no services after {timeout:g} s: {node.output}')

    def wait(self, future, timeout=60.0):
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        assert future.done(), 'no answer'
        return future.result()

    def call(self, name, **fields):
        request = SERVICES[name].Request()
        for key, value in fields.items():
            setattr(request, key, value)
        return self.wait(self.clients[name].call_async(request))

    def state(self, body):
        response = self.call('get_entity_state', entity=body)
        assert response.result.result == Result.RESULT_OK, response.result.error_message
        return response.state

    def set_state(self, target):
        request = SimulationState(state=target)
        return self.call('set_simulation_state', state=request).result

    def close(self):
        self.action.destroy()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def pose_of(state):
    """Return an EntityState's pose as (x, y, z, qx, qy, qz, qw)."""
    p, q = state.pose.position, state.pose.orientation
    return [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
