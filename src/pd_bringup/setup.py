"""Build script of the pd_bringup ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_bringup'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description='Bring-up of a pseudo-dynamic test: run_test starts the integrator, the bridges '
                'and the simulators (or OpenSees sites) as separate processes.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'run_test = pd_bringup.launcher:process_main',
            'keygen = pd_bringup.keygen:main',
            'control = pd_bringup.control:main',
            'fault_proxy = pd_bringup.fault_proxy:main',
        ],
        'pd.commands': [
            'run = pd_bringup.commands:RUN',
            'control = pd_bringup.commands:CONTROL',
            'keygen = pd_bringup.commands:KEYGEN',
        ],
    },
)
