"""Build script of the pd_integrator ament_python package."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'pd_integrator'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
        # the test files of the chapter 5 study (pd_studies reads them from here)
        ('share/' + PACKAGE + '/config/study_ch5', glob('config/study_ch5/*.yaml')),
        ('share/' + PACKAGE + '/data/ground_motions', glob('data/ground_motions/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('Time-stepping node of the pseudo-dynamic test: integrator, ground motions, '
                 'step protocol, bag and outputs.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'main = pd_integrator.node:process_main',
            'offline = pd_integrator.offline:main',
            'replay = pd_integrator.replay:main',
            'recover = pd_integrator.recover:main',
            'journal = pd_integrator.journal:main',
        ],
        'pd.commands': [
            'offline = pd_integrator.commands:OFFLINE',
            'replay = pd_integrator.commands:REPLAY',
            'recover = pd_integrator.commands:RECOVER',
            'journal = pd_integrator.commands:JOURNAL',
        ],
    },
)
