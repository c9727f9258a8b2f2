"""Build script of the pd_actuator_bridge ament_python package."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'pd_actuator_bridge'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('Actuator bridge of the pseudo-dynamic test: enforces its own safety limits '
                 'and drives the actuator controller.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'main = pd_actuator_bridge.node:main',
            'controller_server = pd_actuator_bridge.controller_server:main',
            'opensees_site = pd_actuator_bridge.opensees_site:main',
            'element_server = pd_actuator_bridge.element_server:main',
        ],
        'pd.commands': ['serve = pd_actuator_bridge.commands:SERVE'],
    },
)
